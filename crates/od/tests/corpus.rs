//! The real-world corpus (../shared/eds-corpus, 51 vendor and tool files): every file except the
//! deliberately broken `kaco__401.eds` parses, round-trips through the EDS writer to an equal
//! model, and yields a DCF and a concise DCF; `kaco__401.eds` fails with errors that carry lines.

mod common;

use canola_od::write::{ConciseSelection, concise_dcf, decode_concise};
use canola_od::{ObjectDictionary, Severity, lint, parse, write_dcf, write_eds};

/// Names the first difference between two models, for a readable failure.
fn first_difference(a: &ObjectDictionary, b: &ObjectDictionary) -> String {
    if a.file_info != b.file_info {
        return format!("file_info: {:?} vs {:?}", a.file_info, b.file_info);
    }
    if a.device_info != b.device_info {
        return format!("device_info: {:?} vs {:?}", a.device_info, b.device_info);
    }
    for (i, oa) in &a.objects {
        match b.objects.get(i) {
            None => return format!("object {i:04X} missing after round trip"),
            Some(ob) if ob != oa => {
                for sa in &oa.subs {
                    let s = sa.sub_index;
                    if ob.subs.get(s) != Some(sa) {
                        return format!("{i:04X}sub{s:X}: {sa:?} vs {:?}", ob.subs.get(s));
                    }
                }
                return format!("object {i:04X}: {oa:?} vs {ob:?}");
            }
            _ => {}
        }
    }
    "elsewhere (lists, comments, sections)".into()
}

#[test]
fn corpus_parses_and_round_trips() {
    let Some(dir) = common::corpus_dir("corpus_parses_and_round_trips") else {
        return;
    };
    let files = common::corpus_files(&dir);
    assert!(
        files.len() >= 50,
        "expected the 50 corpus files, found {}",
        files.len()
    );
    let (mut parsed, mut warnings, mut round_trips, mut dcfs, mut lint_findings) = (0, 0, 0, 0, 0);
    let mut failures = Vec::new();
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let bytes = std::fs::read(path).unwrap();
        let result = parse(&bytes);
        if name == common::BROKEN {
            let err = result.expect_err("kaco__401.eds must not parse");
            let errors: Vec<_> = err.errors().collect();
            assert!(!errors.is_empty());
            for e in &errors {
                assert!(e.line > 0, "error without a line: {e}");
                let rendered = e.render(&name).to_string();
                assert!(
                    rendered.starts_with(&format!("{name}:{}: error: ", e.line)),
                    "{rendered}"
                );
            }
            // The first object section's ObjectType carries an inline `# Record` comment.
            assert!(errors[0].message.contains("ObjectType"), "{}", errors[0]);
            println!(
                "{name}: fails as expected with {} errors, first: {}",
                errors.len(),
                errors[0].render(&name)
            );
            continue;
        }
        let p = match result {
            Ok(p) => p,
            Err(e) => {
                failures.push(format!(
                    "{name}: {}",
                    e.errors().next().unwrap().render(&name)
                ));
                continue;
            }
        };
        parsed += 1;
        assert!(
            p.diagnostics
                .iter()
                .all(|d| d.severity == Severity::Warning && d.line > 0 || d.line == 0)
        );
        warnings += p.diagnostics.len();
        let text = write_eds(&p.od);
        match parse(text.as_bytes()) {
            Ok(again) if again.od == p.od => round_trips += 1,
            Ok(again) => failures.push(format!(
                "{name}: round trip differs: {}",
                first_difference(&p.od, &again.od)
            )),
            Err(e) => failures.push(format!("{name}: written EDS does not parse: {e}")),
        }
        let dcf = write_dcf(&p.od, 0x21, Some(500));
        match parse(dcf.as_bytes()) {
            Ok(d) => {
                assert_eq!(
                    d.od.device_commissioning.as_ref().and_then(|c| c.node_id),
                    Some(0x21)
                );
                let concise = concise_dcf(&d.od, 0x21, ConciseSelection::ParameterValues);
                decode_concise(&concise).expect("concise DCF decodes");
                dcfs += 1;
            }
            Err(e) => failures.push(format!("{name}: written DCF does not parse: {e}")),
        }
        let findings = lint(&p.od);
        assert!(findings.iter().all(|d| d.severity == Severity::Warning));
        lint_findings += findings.len();
        println!(
            "{name}: {} objects, {} warnings, {} lint findings",
            p.od.objects.len(),
            p.diagnostics.len(),
            findings.len()
        );
    }
    println!(
        "corpus: {parsed}/{} files parsed, {warnings} warnings, {round_trips} EDS round trips, {dcfs} DCFs, {lint_findings} lint findings",
        files.len() - 1
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(parsed, files.len() - 1);
}
