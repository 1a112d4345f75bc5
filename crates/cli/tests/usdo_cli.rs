//! `canopen usdo read|write` (CANopen FD): against the simulated devices of the in-memory bus
//! opened with `--fd`, against `canopen --fd simulate` in another process over the UDP bus
//! (CAN FD frames in python-can's format), and the clear error on a classic bus.

mod common;
use common::{canopen, stderr, stdout, udp_bus};

const EDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/burkert-generic.eds");

fn fd_node5(args: &[&str]) -> std::process::Output {
    let eds = format!("5={EDS}");
    let mut all = vec!["--fd", "--eds", eds.as_str()];
    all.extend_from_slice(args);
    canopen(&all)
}

#[test]
fn usdo_reads_and_writes_on_the_fd_demo_bus() {
    let o = fd_node5(&["usdo", "read", "5", "0x1017", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), "500\n");
    let o = fd_node5(&["usdo", "read", "5", "0x1008"]);
    assert_eq!(stdout(&o), "Buerkert generic device\n", "{}", stderr(&o));
    let o = fd_node5(&["--json", "usdo", "read", "5", "0x1018", "1"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["value"], 57);
    let o = fd_node5(&["--json", "usdo", "write", "5", "0x1017", "0", "750"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["ok"], true);
}

#[test]
fn usdo_aborts_print_the_cia301_code() {
    let o = fd_node5(&["--json", "usdo", "read", "5", "0x5FFF", "0", "--type", "u8"]);
    assert!(!o.status.success());
    let v: serde_json::Value = serde_json::from_str(stderr(&o).trim()).expect("JSON on stderr");
    assert_eq!(v["abort_code"], "0x06020000", "{v}");
    assert!(
        v["error"].as_str().unwrap().contains("USDO abort 0x33"),
        "{v}"
    );
    // A read-only object refuses a write.
    let o = fd_node5(&["usdo", "write", "5", "0x1018", "1", "7"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("USDO abort 0x32"), "{}", stderr(&o));
}

#[test]
fn usdo_on_a_classic_bus_says_fd_is_not_supported() {
    let eds = format!("5={EDS}");
    let o = canopen(&["--eds", &eds, "usdo", "read", "5", "0x1017"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("FD not supported on the in-memory bus"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn usdo_against_a_simulator_in_another_process_over_the_udp_bus() {
    let bus = udp_bus(5);
    let mut sim = std::process::Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args([
            "--iface",
            &bus,
            "--fd",
            "simulate",
            EDS,
            "--node-id",
            "9",
            "--duration",
            "20",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("simulator starts");
    // Until the simulator answers (it joins the group after starting).
    let mut answer = None;
    for _ in 0..50 {
        let o = canopen(&[
            "--iface", &bus, "--fd", "usdo", "read", "9", "0x1008", "--type", "str",
        ]);
        if o.status.success() {
            answer = Some(stdout(&o));
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let o = canopen(&[
        "--iface", &bus, "--fd", "usdo", "write", "9", "0x1017", "0", "1234", "--type", "u16",
    ]);
    let written = o.status.success();
    let o = canopen(&[
        "--iface", &bus, "--fd", "usdo", "read", "9", "0x1017", "0", "--type", "u16",
    ]);
    let _ = sim.kill();
    let _ = sim.wait();
    assert_eq!(answer.as_deref(), Some("Buerkert generic device\n"));
    assert!(written);
    assert_eq!(stdout(&o), "1234\n", "{}", stderr(&o));
}

/// The Bürkert logbook (0x2003:04, a DOMAIN of some 4 KB): piped, `usdo read` prints it whole
/// in hex and `usdo upload -o` writes the same bytes; to a terminal, `usdo read` says its size
/// and the upload that writes it instead of filling the screen.
#[cfg(unix)]
#[test]
fn a_large_domain_is_uploaded_to_a_file_not_dumped_on_a_terminal() {
    let o = fd_node5(&["usdo", "read", "5", "0x2003", "4"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let hex = stdout(&o).trim().to_string();
    assert!(hex.len() > 2 * 1024, "{} hex digits", hex.len());
    let bytes: Vec<u8> = (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect();
    assert!(bytes.starts_with(b"<?xml"));

    let dir = std::env::temp_dir().join(format!("canopen-usdo-upload-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("logbook.xml");
    let o = fd_node5(&[
        "usdo",
        "upload",
        "5",
        "0x2003",
        "4",
        "-o",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&file).unwrap(), bytes);
    assert!(
        stderr(&o).contains(&format!("{} bytes written to", bytes.len())),
        "{}",
        stderr(&o)
    );
    std::fs::remove_dir_all(&dir).ok();

    // stdout a terminal: the size and the upload to use, no hex.
    use std::os::fd::AsFd as _;
    let pty = nix::pty::openpty(None, None).expect("openpty");
    let eds = format!("5={EDS}");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_canopen"))
        .args(["--fd", "--eds", &eds, "usdo", "read", "5", "0x2003", "4"])
        .stdout(std::process::Stdio::from(
            pty.slave.as_fd().try_clone_to_owned().unwrap(),
        ))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    drop(pty.slave);
    let mut shown = Vec::new();
    let mut buf = [0u8; 4096];
    while let Ok(n) = nix::unistd::read(&pty.master, &mut buf) {
        if n == 0 {
            break;
        }
        shown.extend_from_slice(&buf[..n]);
    }
    assert!(shown.len() < 100, "{}", String::from_utf8_lossy(&shown));
    let err = stderr(&o);
    assert!(
        err.contains(&format!("a DOMAIN of {} bytes", bytes.len())),
        "{err}"
    );
    assert!(
        err.contains("`canopen usdo upload 5 0x2003 4 -o FILE`"),
        "{err}"
    );
}
