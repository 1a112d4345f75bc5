//! `canopen nmt state` (every node's last state and heartbeat age) and `canopen nmt CMD NODE
//! --wait` (waits for the heartbeat or boot-up that confirms the command), against simulated
//! devices: on the in-memory bus (`--eds`) and in other processes on the UDP bus.

mod common;
use common::{canopen, stderr, stdout};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

#[test]
fn state_lists_every_node_heard_with_its_heartbeat_age() {
    let e5 = format!("5={EDS}");
    let e6 = format!("6={EDS}");
    let o = canopen(&["--eds", &e5, "--eds", &e6, "nmt", "state"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(rows.len(), 2, "{text}");
    assert_eq!(rows[0][..2], ["5", "pre-operational"], "{text}");
    assert_eq!(rows[1][..2], ["6", "pre-operational"], "{text}");
    // Heartbeats every 500 ms (0x1017 of this EDS): none is older than that.
    for r in &rows {
        let age: u64 = r[2].parse().unwrap();
        assert!(age <= 500, "{text}");
    }
    let o = canopen(&["--json", "--eds", &e5, "nmt", "state"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v[0]["node"], 5, "{v}");
    assert_eq!(v[0]["state"], "pre-operational", "{v}");
    assert!(v[0]["heartbeat_age_ms"].as_u64().unwrap() <= 500, "{v}");
}

#[test]
fn commands_wait_for_the_state_they_ask_for() {
    let e5 = format!("5={EDS}");
    for (cmd, state) in [
        ("start", "operational"),
        ("stop", "stopped"),
        ("preop", "pre-operational"),
        ("reset", "boot-up"),
        ("reset-comm", "boot-up"),
    ] {
        let o = canopen(&["--eds", &e5, "nmt", cmd, "5", "--wait"]);
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
        assert_eq!(stdout(&o).trim(), format!("node 5: {state}"), "{cmd}");
    }
    let o = canopen(&["--json", "--eds", &e5, "nmt", "start", "5", "--wait"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["nodes"][0]["state"], "operational", "{v}");
}

#[test]
fn several_nodes_are_commanded_and_waited_for() {
    let e5 = format!("5={EDS}");
    let e6 = format!("6={EDS}");
    let o = canopen(&["--eds", &e5, "--eds", &e6, "nmt", "reset", "5,6", "--wait"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "node 5: boot-up\nnode 6: boot-up\n");
    // One of them absent: the other is confirmed (by its next heartbeat, within 500 ms), the
    // absent one is the error.
    let o = canopen(&[
        "--eds",
        &e5,
        "nmt",
        "start",
        "5,7",
        "--wait",
        "--timeout",
        "1000",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stdout(&o), "node 5: operational\n");
    assert!(
        stderr(&o).contains("node 7 did not confirm operational"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_wait_that_is_not_confirmed_is_a_clear_error() {
    let e5 = format!("5={EDS}");
    // Node 7 is not on the bus.
    let o = canopen(&[
        "--eds",
        &e5,
        "nmt",
        "start",
        "7",
        "--wait",
        "--timeout",
        "300",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    let err = stderr(&o);
    assert!(
        err.contains("node 7") && err.contains("operational") && err.contains("300 ms"),
        "{err}"
    );
    assert!(err.contains("nothing heard from node 7"), "{err}");
    // `state` needs no node, the commands need one.
    let o = canopen(&["nmt", "start"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = canopen(&["nmt", "state", "5"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn start_wait_and_state_against_devices_in_other_processes() {
    let iface = common::udp_bus(2);
    let mut sims = [
        common::simulator(&iface, EDS, "5", "30"),
        common::simulator(&iface, EDS, "6", "30"),
    ];
    let o = canopen(&["--iface", &iface, "nmt", "start", "5", "--wait"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "node 5: operational");
    let o = canopen(&["--iface", &iface, "nmt", "state", "--listen", "1.2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let state_of = |node: &str| {
        text.lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>())
            .find(|r| r.first() == Some(&node))
            .map(|r| r[1].to_string())
    };
    assert_eq!(state_of("5").as_deref(), Some("operational"), "{text}");
    assert_eq!(state_of("6").as_deref(), Some("pre-operational"), "{text}");
    // A reset is confirmed by the boot-up.
    let o = canopen(&["--iface", &iface, "nmt", "reset", "6", "--wait"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "node 6: boot-up");
    for s in &mut sims {
        let _ = s.kill();
        let _ = s.wait();
    }
}
