//! The communication profile area (0x1000..0x1FFF) configures the network itself: a value
//! there that does not parse is an error, not text kept aside (an unparsable COB-ID of
//! 0x1800:01 left the simulator sending TPDO 1 on 0x000, the NMT identifier); a strict mode
//! refuses a file with any finding in those objects. Checked against the real-world corpus.

mod common;

use canola_od::{ParseOptions, Severity, parse, parse_with};

fn eds(default: &str) -> String {
    format!(
        "[FileInfo]\nEDSVersion=4.0\n[DeviceInfo]\nVendorNumber=0x123\n\
         [1800]\nParameterName=TPDO communication parameter\nObjectType=0x9\nSubNumber=2\n\
         [1800sub0]\nParameterName=Highest sub-index supported\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\n\
         [1800sub1]\nParameterName=COB-ID used by TPDO\nDataType=0x0007\nAccessType=rw\nDefaultValue={default}\n\
         [2000]\nParameterName=Setpoint\nObjectType=0x7\nDataType=0x0006\nAccessType=rw\nDefaultValue=0xZZ\n"
    )
}

#[test]
fn unparsable_value_of_a_communication_object_is_an_error() {
    let err = parse(eds("$NODEID+0xZZ").as_bytes()).expect_err("0x1800:01 does not parse");
    let errors: Vec<_> = err.errors().collect();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(errors[0].line, 18);
    assert!(
        errors[0].message.contains("DefaultValue") && errors[0].message.contains("communication"),
        "{}",
        errors[0].message
    );
    // The same in a manufacturer object stays a warning: the value is kept as text.
    let p = parse(eds("$NODEID+0x180").as_bytes()).expect("parses");
    let warnings: Vec<_> = p
        .diagnostics
        .iter()
        .filter(|d| d.severity == Severity::Warning && d.message.contains("0xZZ"))
        .collect();
    assert_eq!(warnings.len(), 1, "{:?}", p.diagnostics);
    assert_eq!(warnings[0].line, 24);
    // The warnings come back with the model.
    assert!(!p.diagnostics.is_empty());
}

/// DCF `[xxxxValue]` sections give ParameterValue: the same rule.
#[test]
fn unparsable_parameter_value_of_a_communication_object_is_an_error() {
    let text = eds("$NODEID+0x180") + "[1800Value]\nNrOfEntries=1\n1=0x18G\n";
    let err = parse(text.as_bytes()).expect_err("0x1800:01 value does not parse");
    assert!(err.errors().any(|d| d.line == 27), "{err:?}");
}

/// Strict: any finding in a communication object (save style) refuses the file; the same
/// findings elsewhere stay warnings.
#[test]
fn strict_mode_refuses_findings_in_communication_objects() {
    let text = "[FileInfo]\nEDSVersion=4.0\n[DeviceInfo]\nVendorNumber=0x123\n\
         [1017]\nParameterName=Producer heartbeat time\nObjectType=0x7\nDataType=0x0006\nAccessType=rx\nDefaultValue=0\n\
         [2000]\nParameterName=Setpoint\nObjectType=0x7\nDataType=0x0006\nAccessType=rx\nDefaultValue=0\n";
    let lenient = parse(text.as_bytes()).expect("parses with warnings");
    assert_eq!(
        lenient
            .diagnostics
            .iter()
            .filter(|d| d.message.contains("AccessType"))
            .count(),
        2
    );
    let err = parse_with(text.as_bytes(), ParseOptions::new().strict(true))
        .expect_err("strict refuses the finding in 0x1017");
    let errors: Vec<_> = err.errors().collect();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(errors[0].line, 9);
    // 0x2000's finding is still listed, as a warning.
    assert!(
        err.diagnostics
            .iter()
            .any(|d| d.severity == Severity::Warning && d.line == 15)
    );
}

/// Against the real-world corpus: which files the new error (and strict mode) refuse, and
/// that every file that parsed before and is refused now really has such a value.
#[test]
fn corpus_verdicts_on_communication_objects() {
    let Some(dir) = common::corpus_dir("corpus_verdicts_on_communication_objects") else {
        return;
    };
    let (mut refused, mut strict_refused) = (Vec::new(), Vec::new());
    let files = common::corpus_files(&dir);
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name == common::BROKEN {
            continue;
        }
        let bytes = std::fs::read(path).unwrap();
        match parse(&bytes) {
            Ok(_) => {}
            Err(e) => {
                for d in e.errors() {
                    // The only new reason to refuse a file.
                    assert!(
                        d.message.contains("communication object"),
                        "{name}: {}",
                        d.render(&name)
                    );
                    println!("refused: {}", d.render(&name));
                }
                refused.push(name.clone());
            }
        }
        if let Err(e) = parse_with(&bytes, ParseOptions::new().strict(true)) {
            let first = e.errors().next().unwrap().render(&name).to_string();
            strict_refused.push(format!(
                "{name} ({} errors; first: {first})",
                e.error_count()
            ));
        }
    }
    println!(
        "corpus: {} of {} files refused for an unparsable communication object value: {refused:?}",
        refused.len(),
        files.len() - 1
    );
    println!("strict mode refuses {}:", strict_refused.len());
    for s in &strict_refused {
        println!("  {s}");
    }
}

/// `eds lint`: a COB-ID of a communication object that lands in a CiA 301 restricted range.
#[test]
fn lint_flags_restricted_cob_ids() {
    let text = "[FileInfo]\nEDSVersion=4.0\n[DeviceInfo]\nVendorNumber=0x123\n\
        [1005]\nParameterName=COB-ID SYNC\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x7E5\n\
        [1014]\nParameterName=COB-ID EMCY\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x80\n\
        [1800]\nParameterName=TPDO1\nObjectType=0x9\nSubNumber=2\n\
        [1800sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
        [1800sub1]\nParameterName=COB-ID\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x000\n\
        [1801]\nParameterName=TPDO2\nObjectType=0x9\nSubNumber=2\n\
        [1801sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
        [1801sub1]\nParameterName=COB-ID\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x700\n\
        [1802]\nParameterName=TPDO3\nObjectType=0x9\nSubNumber=2\n\
        [1802sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
        [1802sub1]\nParameterName=COB-ID\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x80000000\n\
        [1803]\nParameterName=TPDO4\nObjectType=0x9\nSubNumber=2\n\
        [1803sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
        [1803sub1]\nParameterName=COB-ID\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x480\n\
        [1400]\nParameterName=RPDO1\nObjectType=0x9\nSubNumber=2\n\
        [1400sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
        [1400sub1]\nParameterName=COB-ID\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x20000000\n";
    let p = parse(text.as_bytes()).expect("parses");
    let found: Vec<_> = canola_od::lint(&p.od)
        .into_iter()
        .filter(|d| d.message.contains("restricted"))
        .collect();
    let lines: Vec<u32> = found.iter().map(|d| d.line).collect();
    // 0x1005 (0x7E5), 0x1800:01 (0x000), 0x1801:01 ($NODEID+0x700); not the EMCY default,
    // the disabled TPDO3, TPDO4's default, nor the 29-bit identifier 0x00000000 of RPDO1.
    assert_eq!(lines, [5, 26, 40], "{found:#?}");
    assert!(
        found[1].message.contains("0x1800:01"),
        "{}",
        found[1].message
    );
    assert!(found[1].message.contains("0x000"), "{}", found[1].message);
}

/// The corpus: how many files set a restricted COB-ID in a communication object.
#[test]
fn corpus_restricted_cob_ids() {
    let Some(dir) = common::corpus_dir("corpus_restricted_cob_ids") else {
        return;
    };
    let mut files = 0;
    for path in common::corpus_files(&dir) {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let Ok(p) = parse(&std::fs::read(&path).unwrap()) else {
            continue;
        };
        let found: Vec<_> = canola_od::lint(&p.od)
            .into_iter()
            .filter(|d| d.message.contains("restricted"))
            .collect();
        if !found.is_empty() {
            files += 1;
        }
        for d in found {
            println!("{}", d.render(&name));
        }
    }
    println!("corpus: {files} files with a restricted COB-ID in a communication object");
}

/// Lint messages write object addresses one way, `0x1018:01`, as `ObjectAddress` does.
#[test]
fn lint_messages_write_addresses_one_way() {
    let text = "[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=3\n\
        [1018sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n\
        [1018sub1]\nParameterName=Vendor\nDataType=0x0009\nAccessType=ro\nPDOMapping=1\n";
    let p = parse(text.as_bytes()).expect("parses");
    let messages: Vec<String> = canola_od::lint(&p.od)
        .into_iter()
        .map(|d| d.message)
        .collect();
    assert!(
        messages
            .iter()
            .any(|m| m.starts_with("0x1018: SubNumber=3")),
        "{messages:#?}"
    );
    assert!(
        messages
            .iter()
            .any(|m| m.starts_with("0x1018:01: PDOMapping=1")),
        "{messages:#?}"
    );
    assert!(
        messages.iter().all(|m| !m.contains("1018sub")),
        "{messages:#?}"
    );
}
