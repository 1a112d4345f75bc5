//! A DCF that would put a COB-ID on a CAN identifier CiA 301 restricts (here SYNC on 0x001):
//! the boot refuses to configure it (code J, the object and the identifier named, nothing
//! written), and `audit` with `fix` refuses to write it back.

use std::path::PathBuf;

use canola::{MemoryBus, Network, NodeId};
use canola_manager::simulate::attach_slaves;
use canola_manager::{
    AuditOptions, BootErrorCode, BootStep, NetworkConfig, SlaveStatus, audit, boot,
};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// valve.dcf with a SYNC COB-ID (0x1005) whose configured value is `value`, in a directory of
/// its own per call (tests running at once with the same value must not share the file: one
/// rewriting it while another reads it gives the reader an empty file).
fn config(value: &str) -> NetworkConfig {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!(
        "canola-manager-restricted-{}-{call}-{value}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let mut text = std::fs::read_to_string(data("valve.dcf")).unwrap();
    text = text.replace(
        "[OptionalObjects]\nSupportedObjects=4\n1=0x100C\n2=0x100D\n3=0x1017\n4=0x1020",
        "[OptionalObjects]\nSupportedObjects=5\n1=0x1005\n2=0x100C\n3=0x100D\n4=0x1017\n5=0x1020",
    );
    text.push_str(&format!(
        "\n[1005]\nParameterName=COB-ID SYNC\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\n\
         DefaultValue=0x00000080\nPDOMapping=0\nParameterValue={value}\n"
    ));
    let dcf = dir.join("valve-sync.dcf");
    std::fs::write(&dcf, text).unwrap();
    let toml = format!(
        "[master]\nnode_id = 1\nsdo_timeout_ms = 100\nboot_timeout_ms = 300\n\
         [[slave]]\nnode_id = 5\ndcf = \"{}\"\nmandatory = true\n",
        dcf.display()
    );
    NetworkConfig::parse(&toml, &dir.join("net.toml")).expect("test description")
}

fn u32_at(net: &Network, index: u16, sub: u8) -> u32 {
    let b = net
        .node(NodeId::new(5).unwrap())
        .sdo()
        .read((index, sub))
        .wait()
        .unwrap();
    let mut a = [0; 4];
    a[..b.len()].copy_from_slice(&b);
    u32::from_le_bytes(a)
}

#[test]
fn boot_refuses_to_configure_a_restricted_cob_id() {
    let config = config("0x00000001");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let report = boot(&net, &config);
    let s = &report.slaves[0];
    assert_eq!(s.status, SlaveStatus::Failed, "{s:?}");
    assert_eq!(s.error_code, Some(BootErrorCode::J));
    assert_eq!(s.step, Some(BootStep::Configuration));
    assert_eq!(s.object.unwrap().to_string(), "0x1005:00");
    let detail = s.detail.as_deref().unwrap();
    assert!(
        detail.contains("node 5") && detail.contains("0x001") && detail.contains("restricts"),
        "{detail}"
    );
    assert!(!report.mandatory_ok);
    // Nothing of the configuration was written.
    assert_eq!(u32_at(&net, 0x1005, 0), 0x80);
    assert_eq!(u32_at(&net, 0x2001, 0), 0);
}

#[test]
fn audit_fix_refuses_to_write_a_restricted_cob_id_back() {
    let config = config("0x00000001");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let report = audit(
        &net,
        &config,
        AuditOptions {
            fix: true,
            ..AuditOptions::default()
        },
    );
    let d = report.slaves[0]
        .differences
        .iter()
        .find(|d| d.object.index == 0x1005)
        .expect("0x1005 differs");
    match &d.fixed {
        Some(Err(e)) => assert!(e.contains("0x001") && e.contains("restricts"), "{e}"),
        other => panic!("{other:?}"),
    }
    assert_eq!(u32_at(&net, 0x1005, 0), 0x80);
}

#[test]
fn an_allowed_sync_cob_id_is_configured() {
    let config = config("0x00000081");
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    attach_slaves(&bus, &config, &[]);
    let report = boot(&net, &config);
    assert!(report.mandatory_ok, "{report:?}");
    assert_eq!(u32_at(&net, 0x1005, 0), 0x81);
}
