//! Simulated devices behind the CLI: an EDS with the Bürkert profile gets the Bürkert device
//! (logbook, locating, NE 107), any other EDS the generic simulator.

use std::path::Path;

mod common;
use common::canopen;

fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
        .display()
        .to_string()
}

#[test]
fn burkert_eds_node_serves_the_xml_logbook() {
    let dir = std::env::temp_dir().join(format!("canopen-sim-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out_file = dir.join("logbook.xml");
    let eds = format!("5={}", repo("eds/burkert-generic.eds"));
    let out = canopen(&[
        "--eds",
        &eds,
        "sdo",
        "upload",
        "5",
        "0x2003",
        "4",
        "-o",
        &out_file.display().to_string(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let xml = std::fs::read_to_string(&out_file).unwrap();
    assert!(
        xml.starts_with("<?xml"),
        "the Bürkert device's logbook, not an empty DOMAIN: {xml:.60}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn simulate_boots_and_sends_heartbeats_every_500_ms() {
    let out = canopen(&[
        "simulate",
        &repo("eds/burkert-generic.eds"),
        "--node-id",
        "7",
        "--duration",
        "1.2",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let frames: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect();
    let heartbeats: Vec<(f64, String)> = frames
        .iter()
        .filter(|f| f["frame"].as_str().is_some_and(|s| s.starts_with("707#")))
        .map(|f| {
            (
                f["time"].as_f64().unwrap(),
                f["frame"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    assert_eq!(
        heartbeats.first().map(|h| h.1.as_str()),
        Some("707#00"),
        "boot-up first: {heartbeats:?}"
    );
    assert!(
        heartbeats[1..].iter().all(|h| h.1 == "707#7F"),
        "then pre-operational heartbeats: {heartbeats:?}"
    );
    assert_eq!(
        heartbeats.len(),
        3,
        "boot-up plus heartbeats at 0.5 s and 1.0 s: {heartbeats:?}"
    );
    let gap = heartbeats[2].0 - heartbeats[1].0;
    assert!((gap - 0.5).abs() < 0.01, "heartbeat period {gap} s");
}
