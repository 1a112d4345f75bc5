//! `canopen burkert ...` run as a binary against a Bürkert device simulated on the in-memory
//! bus (no `--iface`).

use std::process::Output;

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_str(&stdout(o)).unwrap_or_else(|e| panic!("{e}: {}", stdout(o)))
}

#[test]
fn status_text_and_json() {
    let o = canopen(&["burkert", "status", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t = stdout(&o);
    assert!(t.contains("node 5: Generic device"), "{t}");
    assert!(t.contains("diagnosis inactive / Diagnose inaktiv"), "{t}");
    assert!(t.contains("white / weiß"), "{t}");
    assert!(t.contains("pre-operational"), "{t}");
    // Not a terminal: no escape sequences.
    assert!(!t.contains('\x1b'), "{t}");

    let eds = format!("7={EDS}");
    let v = json(&canopen(&[
        "--eds", &eds, "--json", "burkert", "status", "7",
    ]));
    assert_eq!(v["node"], 7);
    assert_eq!(v["description"]["device_name"], "Generic device");
    assert_eq!(v["status"]["ne107"]["value"], 0);
    assert_eq!(v["status"]["boot_counter"], 1);
    assert_eq!(v["communication"]["bit_rate_kbit"], 500);
    assert_eq!(v["communication"]["address"], 7);
    assert_eq!(v["led"]["mode"], "namur");
    assert_eq!(v["led"]["colour"], "white");
    assert_eq!(v["led"]["code"], 0x1000_0001u32);
    assert_eq!(v["locating"], false);
}

#[test]
fn locate_starts_flashing() {
    let o = canopen(&["burkert", "locate", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("(flashing)"), "{}", stdout(&o));
    let v = json(&canopen(&["--json", "burkert", "locate", "5"]));
    assert_eq!(v["locating"], true);
    assert_eq!(v["led"]["flashing"], true);
    let v = json(&canopen(&["--json", "burkert", "locate", "5", "--stop"]));
    assert_eq!(v["locating"], false);
}

#[test]
fn maintenance_on_shows_blue() {
    let v = json(&canopen(&["--json", "burkert", "maintenance", "5", "on"]));
    assert_eq!(v["maintenance"], true);
    assert_eq!(v["ne107"]["value"], 2);
    assert_eq!(v["ne107"]["en"], "maintenance required");
    assert_eq!(v["led"]["colour"], "blue");
    let o = canopen(&["burkert", "maintenance", "5", "off"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("maintenance off"), "{}", stdout(&o));
}

#[test]
fn led_mode_and_colour() {
    let v = json(&canopen(&[
        "--json", "burkert", "led", "5", "--mode", "fixed", "--colour", "#00FFFF",
    ]));
    assert_eq!(v["led"]["mode"], "fixed");
    assert_eq!(v["led"]["mode_value"], 4);
    assert_eq!(v["led"]["colour"], "#00FFFF");
    assert_eq!(v["led"]["code"], 0x00FF_FF00u32);
    let v = json(&canopen(&[
        "--json", "burkert", "led", "5", "--mode", "fixed", "--colour", "rot",
    ]));
    assert_eq!(v["led"]["colour"], "red");
    let v = json(&canopen(&[
        "--json", "burkert", "led", "5", "--mode", "off",
    ]));
    assert_eq!(v["led"]["colour"], "off");
    let o = canopen(&["burkert", "led", "5", "--mode", "blink"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("blink"), "{}", stderr(&o));
    let o = canopen(&["burkert", "led", "5", "--mode", "fixed", "--colour", "#12"]);
    assert!(!o.status.success());
}

#[test]
fn logbook_to_file() {
    let dir = std::env::temp_dir().join(format!("canopen-burkert-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("logbook.xml");
    let f = file.to_str().unwrap();
    let v = json(&canopen(&["--json", "burkert", "logbook", "5", "-o", f]));
    let xml = std::fs::read_to_string(&file).unwrap();
    assert_eq!(v["bytes"], xml.len());
    assert_eq!(v["transfer"], "block");
    assert!(xml.starts_with("<?xml"), "{xml}");
    assert!(xml.contains("<logbook "), "{xml}");
    assert!(xml.len() > 2048);
    let o = canopen(&["burkert", "logbook", "5", "-o", f, "--segmented"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("bytes, written to"), "{}", stdout(&o));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), xml);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_device_without_the_object_fails_naming_node_object_and_abort() {
    // The generic EDS without the locating object 0x2101.
    let text = std::fs::read_to_string(EDS).unwrap();
    let mut out = String::new();
    let mut skip = false;
    for line in text.lines() {
        if line.starts_with('[') {
            skip = line.starts_with("[2101");
        }
        if !skip && !line.trim().ends_with("=0x2101") {
            out.push_str(line);
            out.push('\n');
        }
    }
    let dir = std::env::temp_dir().join(format!("canopen-burkert-cli-eds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("no-locate.eds");
    std::fs::write(&file, out).unwrap();
    let eds = format!("5={}", file.display());
    let o = canopen(&["--eds", &eds, "burkert", "locate", "5"]);
    assert!(!o.status.success());
    assert!(stdout(&o).is_empty());
    let e = stderr(&o);
    assert!(e.contains("node 5"), "{e}");
    assert!(e.contains("0x2101"), "{e}");
    assert!(e.contains("0x06020000"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn simulate_on_the_in_memory_bus_prints_boot_up_and_heartbeats() {
    let o = canopen(&[
        "burkert",
        "simulate",
        "5",
        "--event",
        "failure",
        "--duration",
        "1.2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("failure"), "{}", stderr(&o));
    let t = stdout(&o);
    let lines: Vec<&str> = t.lines().collect();
    // Boot-up, then heartbeats at 0.5 s and 1.0 s.
    assert_eq!(lines.len(), 3, "{t}");
    assert!(lines.iter().all(|l| l.contains("705")), "{t}");
    let o = canopen(&["burkert", "simulate", "5"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--duration"), "{}", stderr(&o));
}
