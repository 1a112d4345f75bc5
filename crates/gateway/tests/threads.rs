//! The gateway's own threads (alone in this test binary, so that no other gateway's threads are
//! counted): requests to many nodes are served by the one dispatcher, with no thread per node;
//! LSS requests add one thread for the bus; shutdown joins them all.

mod common;

use canola_gateway::Config;
use common::{Client, gateway};

/// The names of this process's threads that the gateway made (`gateway-...`, cut to the 15
/// bytes Linux keeps of a thread's name) that serve requests: the event thread is left out, as
/// it names itself only once it first runs, which it need not have done yet.
#[cfg(target_os = "linux")]
fn gateway_threads() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir("/proc/self/task")
        .unwrap()
        .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("comm")).ok())
        .map(|n| n.trim_end().to_owned())
        .filter(|n| n.starts_with("gateway-") && n != "gateway-events")
        .collect();
    names.sort();
    names
}

#[cfg(target_os = "linux")]
#[test]
fn one_dispatcher_serves_every_node() {
    let nodes: Vec<u8> = (1..=12).collect();
    let (gw, _bus) = gateway(&nodes, Config::default());
    let mut c = Client::connect(&gw);
    let text: String = nodes
        .iter()
        .map(|n| format!("[{n}] {n} r 0x1017 0 u16\n[{n}] {n} w 0x1017 0 u16 {n}\n"))
        .collect();
    c.send(&text);
    let mut replies: Vec<String> = (0..2 * nodes.len()).map(|_| c.line()).collect();
    replies.sort();
    let mut expected: Vec<String> = nodes
        .iter()
        .flat_map(|n| [format!("[{n}] 500\r\n"), format!("[{n}] OK\r\n")])
        .collect();
    expected.sort();
    assert_eq!(replies, expected);
    assert_eq!(gateway_threads(), ["gateway-dispatc"]);

    // LSS requests (nobody answers a switch to waiting) run on one more thread.
    assert_eq!(
        c.ask("[30] lss_switch_glob 0\n[31] lss_switch_glob 0\n", 2),
        "[30] OK\r\n[31] OK\r\n"
    );
    assert_eq!(gateway_threads(), ["gateway-dispatc", "gateway-lss"]);
    gw.shutdown();
    assert!(gateway_threads().is_empty(), "{:?}", gateway_threads());
}
