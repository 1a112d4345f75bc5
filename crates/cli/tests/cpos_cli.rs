//! `canopen cpos ...` run as a process against the simulated GEMÜ 1436 cPos.

mod common;
use common::{canopen, stdout};

#[test]
fn demo_shows_every_init_valve_phase() {
    let out = canopen(&["cpos", "demo"]);
    assert!(out.status.success(), "{out:?}");
    let text = stdout(&out);
    for phase in [
        "determining the closed position (0x00000001)",
        "determining the open position (0x00000002)",
        "determining the valve control function (0x00000003)",
        "measuring the opening and closing times (0x00000004)",
        "measuring the valve characteristics (0x00000005)",
        "checking the pilot valves (0x00000006)",
        "ended: initialisation inactive",
        "parameter adjTimeClose (0x0835) changed to 23",
        "valve initialised: true",
    ] {
        assert!(text.contains(phase), "missing {phase:?} in\n{text}");
    }
}

#[test]
fn get_and_set_by_name_with_json() {
    let out = canopen(&["--json", "cpos", "set", "Mode", "manual"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    assert_eq!(v["id"], 100);
    assert_eq!(v["value"], 2);
    assert_eq!(v["label"], "Manual");
    let out = canopen(&["cpos", "get", "0x0834"]);
    assert_eq!(stdout(&out).trim(), "CtrlFn (0x0834) = 0 (NC)");
    // Range and access are checked before sending.
    let out = canopen(&["cpos", "set", "openTight", "10"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("below the minimum 800"));
    let out = canopen(&["cpos", "set", "Pot Min", "10"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("read-only"));
}

#[test]
fn error_list_and_refused_actions() {
    let out = canopen(&[
        "--json",
        "cpos",
        "--raise-error",
        "20",
        "--raise-error",
        "22",
        "errors",
    ]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    assert_eq!(v["error_list"][0]["code"], 22);
    assert_eq!(v["error_list"][1]["name"], "PotWrongDir");
    assert_eq!(v["active_errors"].as_array().unwrap().len(), 2);
    let out = canopen(&["cpos", "--no-air", "action", "init-valve"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("Init Valve cannot be started"));
    let out = canopen(&["cpos", "--initialised", "action", "no-init", "open-fast"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("diagnostic 0x42"));
    let out = canopen(&[
        "--json",
        "cpos",
        "action",
        "init-valve",
        "--fault",
        "22",
        "--fault-step",
        "3",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    let events = v["events"].as_array().unwrap();
    assert!(events.iter().any(|e| e["value"] == 0x16FE));
    assert!(events.iter().any(|e| e["value"] == 0x16FF));
}

/// The same commands with the image carried over DeviceNet (Predefined Master/Slave Connection
/// Set on the in-memory bus) to a simulated cPos behind a DeviceNet slave.
#[test]
fn commands_over_devicenet_on_the_in_memory_bus() {
    let out = canopen(&[
        "--json",
        "cpos",
        "--over-devicenet",
        "set",
        "Mode",
        "manual",
    ]);
    assert!(out.status.success(), "{out:?}");
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    assert_eq!(v["value"], 2);
    let out = canopen(&["cpos", "--over-devicenet", "--mac", "12", "get", "CtrlFn"]);
    assert_eq!(stdout(&out).trim(), "CtrlFn (0x0834) = 0 (NC)");
    // The device's diagnostics come through the explicit connection.
    let out = canopen(&[
        "cpos",
        "--over-devicenet",
        "--initialised",
        "action",
        "no-init",
        "open-fast",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("diagnostic 0x42"));
    let out = canopen(&[
        "cpos",
        "--over-devicenet",
        "--no-air",
        "action",
        "init-valve",
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("Init Valve cannot be started"));
    let out = canopen(&[
        "--json",
        "cpos",
        "--over-devicenet",
        "--raise-error",
        "22",
        "errors",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    assert_eq!(v["error_list"][0]["code"], 22);
    assert_eq!(v["active_errors"].as_array().unwrap().len(), 1);
    let out = canopen(&["cpos", "--over-devicenet", "demo"]);
    assert!(out.status.success(), "{out:?}");
    let text = stdout(&out);
    assert!(text.contains("over DeviceNet"));
    assert!(text.contains("ended: initialisation inactive"), "{text}");
    // GoOpen approach, then adopt after 2 s.
    let out = canopen(&[
        "cpos",
        "--over-devicenet",
        "--initialised",
        "action",
        "go-open",
    ]);
    assert!(out.status.success(), "{out:?}");
    assert!(stdout(&out).contains("GoOpen: ended"), "{}", stdout(&out));
}

#[test]
fn devicenet_options_are_checked() {
    // Short images carry no parameter channel.
    let out = canopen(&[
        "cpos",
        "--over-devicenet",
        "--send",
        "5",
        "--receive",
        "3",
        "get",
        "Mode",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("no parameter channel"),
        "{out:?}"
    );
    // Sizes the cPos does not offer.
    let out = canopen(&["cpos", "--over-devicenet", "--send", "6", "get", "Mode"]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("not a cPos setting"),
        "{out:?}"
    );
    let out = canopen(&["cpos", "--mac", "64", "get", "Mode"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("out of range"));
    // --fault needs the in-process simulator.
    let out = canopen(&[
        "cpos",
        "--over-devicenet",
        "action",
        "init-valve",
        "--fault",
        "22",
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("in-process simulator"));
}

#[test]
fn simulate_on_the_in_memory_bus() {
    let out = canopen(&["cpos", "simulate"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--duration"));
    // Alone on the bus it passes its Duplicate MAC ID check (two requests, 1 s apart) and waits.
    let out = canopen(&[
        "--json",
        "cpos",
        "--mac",
        "5",
        "simulate",
        "--duration",
        "3",
    ]);
    assert!(out.status.success(), "{out:?}");
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).unwrap();
    assert_eq!(v["event"], "on line (Duplicate MAC ID check passed)");
    assert_eq!(v["time"], 2.0);
}

/// `cpos` fails as every command does: a usage error exits 2, a refusal 1, and under `--json`
/// each is one JSON object on stderr with nothing on stdout.
#[test]
fn cpos_errors_follow_the_exit_code_and_json_rules() {
    let out = canopen(&["--json", "cpos", "get", "No Such Parameter"]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    assert!(stdout(&out).is_empty(), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    let v: serde_json::Value =
        serde_json::from_str(err.trim()).unwrap_or_else(|e| panic!("{e}: {err}"));
    assert!(v["error"].as_str().unwrap().contains("no parameter"), "{v}");
    assert_eq!(v["usage"], true, "{v}");

    let out = canopen(&["--json", "cpos", "--no-air", "action", "init-valve"]);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(stdout(&out).is_empty(), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    let v: serde_json::Value =
        serde_json::from_str(err.trim()).unwrap_or_else(|e| panic!("{e}: {err}"));
    assert!(
        v["error"]
            .as_str()
            .unwrap()
            .contains("Init Valve cannot be started"),
        "{v}"
    );

    let out = canopen(&["--json", "cpos", "simulate"]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    let v: serde_json::Value =
        serde_json::from_str(err.trim()).unwrap_or_else(|e| panic!("{e}: {err}"));
    assert!(v["error"].as_str().unwrap().contains("--duration"), "{v}");
}
