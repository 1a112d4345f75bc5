//! What the CLI tests share: running the `canopen` binary and reading its output.
#![allow(dead_code)] // each test file uses the part it needs

use std::process::{Command, Output};

/// Runs `canopen ARGS...` to completion.
pub(crate) fn canopen(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Its standard output as text.
pub(crate) fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Its standard error as text.
pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A UDP multicast bus of this test process's own (`udp:GROUP:PORT`, from the process ID and
/// `salt` 0..=7), so parallel tests and runs do not meet.
pub(crate) fn udp_bus(salt: u16) -> String {
    assert!(salt < 8);
    let port = 30000 + (std::process::id() % 4000) as u16 * 8 + salt;
    format!("udp:239.74.163.{}:{port}", 10 + salt)
}

/// Starts `canopen --iface IFACE simulate EDS --node-id NODE --duration SECS` and waits until
/// the device answers an SDO read of 0x1000.
pub(crate) fn simulator(iface: &str, eds: &str, node: &str, secs: &str) -> std::process::Child {
    let mut child = Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            iface,
            "simulate",
            eds,
            "--node-id",
            node,
            "--duration",
            secs,
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("simulate starts");
    for _ in 0..50 {
        if canopen(&["--iface", iface, "sdo", "read", node, "0x1000"])
            .status
            .success()
        {
            return child;
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    panic!("the simulator never answered on {iface}");
}
