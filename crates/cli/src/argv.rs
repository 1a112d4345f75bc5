//! Options after values that follow `--`.
//!
//! `--` ends the options for clap: everything after it is a value. That is how a value that
//! starts with `-` gets through (`sdo write 4 0x2120 1 -- -0x10`), but it also swallows the
//! options people type after the value (`sdo write 4 0x2120 1 -- -42 --type i64`), which clap
//! then refuses as surplus values. So before clap parses, [`options_after_values`] moves every
//! option of the chosen command that follows the first value after `--` back in front of the
//! `--`. The token right after `--` always stays a value, so `--` still passes any one value
//! (`sdo write 4 0x2000 -- --type --type str` writes the text `--type`).

use std::ffi::OsString;

use clap::{Arg, Command};

/// The options a command accepts: long names, short letters, and whether each takes a value.
struct Known {
    long: Vec<(String, bool)>,
    short: Vec<(char, bool)>,
}

impl Known {
    fn add(&mut self, arg: &Arg) {
        if arg.is_positional() {
            return;
        }
        let takes = arg.get_action().takes_values();
        for l in arg.get_long_and_visible_aliases().into_iter().flatten() {
            self.long.push((l.to_owned(), takes));
        }
        for s in arg.get_short_and_visible_aliases().into_iter().flatten() {
            self.short.push((s, takes));
        }
    }

    /// How many tokens the option starting at `token` spans (1 or 2), `None` when `token` is
    /// not one of the options.
    fn span(&self, token: &str) -> Option<usize> {
        if let Some(long) = token.strip_prefix("--") {
            let (name, inline) = match long.split_once('=') {
                Some((n, _)) => (n, true),
                None => (long, false),
            };
            let (_, takes) = self.long.iter().find(|(l, _)| l == name)?;
            return Some(if *takes && !inline { 2 } else { 1 });
        }
        let mut chars = token.strip_prefix('-')?.chars();
        let c = chars.next()?;
        let (_, takes) = self.short.iter().find(|(s, _)| *s == c)?;
        let attached = chars.next().is_some();
        match (takes, attached) {
            (true, false) => Some(2),
            (true, true) => Some(1),
            (false, false) => Some(1),
            // `-xyz` with a flag `x`: not an option we move (a negative number, or a cluster).
            (false, true) => None,
        }
    }
}

/// `args` (the program name first) with the options that follow a value after `--` moved in
/// front of the `--` (see the module docs). Arguments that are not UTF-8 are left as they are.
pub(crate) fn options_after_values(cmd: &Command, args: Vec<OsString>) -> Vec<OsString> {
    let Some(dashes) = args.iter().position(|a| a == "--") else {
        return args;
    };
    let Some(text) = args
        .iter()
        .map(|a| a.to_str().map(str::to_owned))
        .collect::<Option<Vec<String>>>()
    else {
        return args;
    };
    let mut cmd = cmd.clone();
    cmd.build();
    let known = options_of(&cmd, text.get(1..dashes).unwrap_or_default());
    let mut moved: Vec<String> = Vec::new();
    let mut kept: Vec<String> = Vec::new();
    let mut i = dashes + 1;
    while let Some(token) = text.get(i) {
        let span = if i > dashes + 1 {
            known.span(token)
        } else {
            None
        };
        match span {
            Some(n) => {
                moved.extend(text.iter().skip(i).take(n).cloned());
                i += n;
            }
            None => {
                kept.push(token.clone());
                i += 1;
            }
        }
    }
    let mut out: Vec<String> = text.get(..dashes).unwrap_or_default().to_vec();
    out.extend(moved);
    out.push("--".into());
    out.extend(kept);
    out.into_iter().map(OsString::from).collect()
}

/// Whether `args` (the program name first) ask for `--json` ahead of any `--`: read before clap
/// parses, so that a command line clap refuses is reported as JSON too.
pub(crate) fn asks_for_json(args: &[OsString]) -> bool {
    args.iter()
        .skip(1)
        .take_while(|a| *a != "--")
        .any(|a| a == "--json")
}

/// The options of the subcommand `before` (the arguments ahead of `--`) selects, with the
/// global options of every command on the way.
fn options_of(root: &Command, before: &[String]) -> Known {
    let mut known = Known {
        long: Vec::new(),
        short: Vec::new(),
    };
    let mut cmd = root;
    root.get_arguments().for_each(|a| known.add(a));
    let mut skip_value = false;
    for token in before {
        if skip_value {
            skip_value = false;
            continue;
        }
        if token.starts_with('-') {
            skip_value = known.span(token) == Some(2);
            continue;
        }
        if let Some(sub) = cmd
            .get_subcommands()
            .find(|s| s.get_name() == token || s.get_all_aliases().any(|a| a == token))
        {
            cmd = sub;
            sub.get_arguments().for_each(|a| known.add(a));
        }
    }
    known
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory as _;

    fn run(line: &str) -> String {
        let args = std::iter::once("canopen")
            .chain(line.split(' '))
            .map(OsString::from)
            .collect();
        let out = options_after_values(&crate::Cli::command(), args);
        let out: Vec<_> = out.iter().skip(1).map(|a| a.to_str().unwrap()).collect();
        out.join(" ")
    }

    #[test]
    fn options_after_the_value_move_in_front_of_the_dashes() {
        assert_eq!(
            run("sdo write 4 0x2120 1 -- -42 --type i64"),
            "sdo write 4 0x2120 1 --type i64 -- -42"
        );
        assert_eq!(
            run("sdo write 4 0x2120 -- -42 -t i64 --json --block"),
            "sdo write 4 0x2120 -t i64 --json --block -- -42"
        );
        assert_eq!(
            run("sdo write 4 0x2120 1 -- -0x10 --type=i16 -ti8 --iface vcan0"),
            "sdo write 4 0x2120 1 --type=i16 -ti8 --iface vcan0 -- -0x10"
        );
        assert_eq!(
            run("cpos set Offset -- -5 --json"),
            "cpos set Offset --json -- -5"
        );
    }

    #[test]
    fn json_is_seen_before_the_dashes_only() {
        let args = |line: &str| -> Vec<OsString> {
            std::iter::once("canopen")
                .chain(line.split(' '))
                .map(OsString::from)
                .collect()
        };
        assert!(asks_for_json(&args("--json sdo read 128 0x1017")));
        assert!(asks_for_json(&args("sdo read 128 0x1017 --json")));
        assert!(!asks_for_json(&args("sdo write 4 0x2000 -- --json")));
        assert!(!asks_for_json(&args("sdo read 4 0x1017")));
    }

    #[test]
    fn the_token_after_the_dashes_stays_a_value() {
        assert_eq!(
            run("sdo write 4 0x2000 -- --type --type str"),
            "sdo write 4 0x2000 --type str -- --type"
        );
        // Not options of the command: values.
        assert_eq!(
            run("sdo write 4 0x2000 -- -1 --bogus -7"),
            "sdo write 4 0x2000 -- -1 --bogus -7"
        );
        // Without `--` nothing changes.
        assert_eq!(
            run("sdo write 4 0x2000 1 -42 --type i64"),
            "sdo write 4 0x2000 1 -42 --type i64"
        );
        // An option's value ahead of `--` is not taken for a subcommand.
        assert_eq!(
            run("--iface sdo sdo write 4 0x2000 -- -1 -t i8"),
            "--iface sdo sdo write 4 0x2000 -t i8 -- -1"
        );
    }
}
