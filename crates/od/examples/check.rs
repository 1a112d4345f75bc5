//! Parses EDS/DCF files and prints the diagnostics, with `--lint` also the linter's findings
//! (a development aid: `cargo run -p canola-od --example check -- [--lint] FILE...`).
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut failed = false;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let lint = args.iter().any(|a| a == "--lint");
    for path in args.into_iter().filter(|a| a != "--lint") {
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{path}: {e}");
                failed = true;
                continue;
            }
        };
        match canola_od::parse(&bytes) {
            Ok(p) => {
                for d in &p.diagnostics {
                    eprintln!("{}", d.render(&path));
                }
                if lint {
                    for d in canola_od::lint(&p.od) {
                        eprintln!("{} [lint]", d.render(&path));
                    }
                }
                println!(
                    "{path}: ok, {} objects, {} warnings",
                    p.od.objects.len(),
                    p.diagnostics.len()
                );
            }
            Err(e) => {
                for d in &e.diagnostics {
                    eprintln!("{}", d.render(&path));
                }
                println!("{path}: FAILED");
                failed = true;
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
