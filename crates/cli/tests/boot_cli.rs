//! `canopen boot` and `canopen audit` run as a binary on the in-memory bus, the slaves of the
//! description simulated from their DCFs.

mod common;
use common::{canopen, stdout};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../manager/tests/data");

fn three() -> String {
    format!("{DATA}/three.toml")
}

#[test]
fn boot_text_and_json() {
    let o = canopen(&["boot", &three()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t = stdout(&o);
    assert!(t.contains("node   5  operational"), "{t}");
    assert!(t.contains("3 operational"), "{t}");

    let o = canopen(&["boot", &three(), "--json", "--absent", "7"]);
    assert!(
        o.status.success(),
        "an optional slave absent does not fail the boot"
    );
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let slaves = j["slaves"].as_array().unwrap();
    assert_eq!(slaves.len(), 3);
    assert_eq!(slaves[0]["node_id"], 5);
    assert_eq!(slaves[0]["status"], "operational");
    assert_eq!(slaves[0]["error_code"], serde_json::Value::Null);
    assert_eq!(slaves[0]["configuration"], "written");
    assert_eq!(slaves[2]["node_id"], 7);
    assert_eq!(slaves[2]["status"], "absent");
    assert_eq!(slaves[2]["error_code"], "B");
    assert_eq!(slaves[2]["step"], "device-present");
    assert_eq!(slaves[2]["object"], "0x1000:00");
    assert_eq!(slaves[2]["abort_code"], "0x05040000");
    assert_eq!(j["mandatory_ok"], true);
}

#[test]
fn absent_mandatory_slave_fails_the_boot() {
    let o = canopen(&["boot", &three(), "--absent", "6"]);
    assert_eq!(o.status.code(), Some(1));
    let t = stdout(&o);
    assert!(t.contains("node   6  absent          error B"), "{t}");
    assert!(t.contains("node   5  pre-operational"), "{t}");
    assert!(t.contains("no start-all"), "{t}");
}

#[test]
fn description_errors_name_line_and_key() {
    let dir = std::env::temp_dir().join(format!("canopen-boot-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bus.toml");
    std::fs::write(
        &file,
        "[master]\nnode_id = 1\n\n[[slave]]\nnode_id = 200\ndcf = \"x.dcf\"\n",
    )
    .unwrap();
    let o = canopen(&["boot", file.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(e.contains("bus.toml:5: slave[1].node_id"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn audit_is_clean_after_boot() {
    let o = canopen(&["audit", &three(), "--json"]);
    assert!(o.status.success(), "{}", stdout(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["clean"], true);
    assert_eq!(j["slaves"][0]["checked"], 6);
    // An absent slave's objects cannot be read: the audit says so and fails.
    let o = canopen(&["audit", &three(), "--absent", "7"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stdout(&o).contains("node   7: 3 objects checked, 0 differ, 3 unreadable"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn master_dcf_written_and_booted_from() {
    let dir = std::env::temp_dir().join(format!("canopen-boot-cli-master-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let master = dir.join("master.dcf");
    let o = canopen(&[
        "boot",
        &three(),
        "--write-master-dcf",
        master.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = canopen(&["eds", "check", master.to_str().unwrap()]);
    assert!(
        o.status.success(),
        "{}{}",
        stdout(&o),
        String::from_utf8_lossy(&o.stderr)
    );
    // Only slave 5 listed: 6 and 7 come from 0x1F81/0x1F22 (simulated from the concise DCFs,
    // which carry no 0x1000, so those two fail the device-present check).
    let bus = dir.join("bus.toml");
    std::fs::write(
        &bus,
        format!("[master]\ndcf = \"master.dcf\"\nsdo_timeout_ms = 50\nboot_timeout_ms = 50\n[[slave]]\nnode_id = 5\ndcf = \"{DATA}/valve.dcf\"\n"),
    )
    .unwrap();
    let o = canopen(&["boot", bus.to_str().unwrap(), "--json"]);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let slaves = j["slaves"].as_array().unwrap();
    assert_eq!(slaves.len(), 3);
    assert_eq!(slaves[0]["status"], "pre-operational");
    assert_eq!(slaves[1]["node_id"], 6);
    assert_eq!(slaves[1]["mandatory"], true);
    assert_eq!(slaves[1]["error_code"], "B");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn supervise_keeps_the_network_and_reports_at_the_end() {
    let o = canopen(&["boot", &three(), "--supervise", "0.3", "--json"]);
    assert!(o.status.success());
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    for s in j["slaves"].as_array().unwrap() {
        assert_eq!(s["status"], "operational", "{s}");
    }
}
