//! Boots 64 simulated slaves, 40 configured objects each, on the in-memory bus with the
//! 1 Mbit/s timing model, and prints side by side: the parallel boot's bus time, the time the
//! wire was busy with the boot's frames (the bound no boot can beat), and the same slaves booted
//! one after another (the way a serial configuration loop such as python-canopen's
//! `load_configuration()` does it: a model on the same bus, python-canopen itself is not run).
//!
//! `cargo run --release -p canola-manager --example boot_bench`

use canola::{BusConfig, MemoryBus, Network, SimDevice};
use canola_manager::config::{ErrorControl, NetworkConfig};
use canola_manager::simulate::factory_dictionary;
use canola_manager::{SlaveStatus, boot};

const SLAVES: u8 = 64;
const OBJECTS: u16 = 40;

fn description() -> NetworkConfig {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
    let mut text = String::from("[master]\nsdo_timeout_ms = 100\n");
    for n in 2..2 + SLAVES {
        text.push_str(&format!(
            "[[slave]]\nnode_id = {n}\neds = \"valve-nostamp.dcf\"\nmandatory = true\nerror_control = \"none\"\n[slave.identity]\nvendor_id = 0x39\nproduct_code = 0x1234\n[slave.values]\n\"0x1017\" = 0\n"
        ));
    }
    let mut config = NetworkConfig::parse(&text, &std::path::Path::new(dir).join("bench.toml"))
        .expect("bench description");
    // Pad every dictionary to OBJECTS configured entries (0x2000.. are three of them).
    for s in &mut config.slaves {
        s.error_control = ErrorControl::None;
        let mut have = canola_manager::boot::configured_values(s).len() as u16;
        let mut index = 0x2100;
        while have < OBJECTS {
            let mut sub = canola::od::SubObject::new(
                0,
                format!("Parameter {index:#06x}"),
                canola::DataType::Unsigned32,
                canola::od::AccessType::Rw,
            );
            sub.default_value =
                Some(canola::od::FieldValue::from_text(canola::DataType::Unsigned32, "0").0);
            sub.extras_mut().parameter_value = Some(
                canola::od::FieldValue::from_text(
                    canola::DataType::Unsigned32,
                    &format!("{}", index as u32 * 3),
                )
                .0,
            );
            s.dictionary.insert(canola::od::Object::var(index, sub));
            index += 1;
            have += 1;
        }
    }
    config
}

fn bus() -> MemoryBus {
    MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        ..BusConfig::default()
    })
}

fn main() {
    let config = description();

    // All slaves at once.
    let b = bus();
    let net = Network::new(b.endpoint());
    for s in &config.slaves {
        b.attach(SimDevice::new(s.node_id, factory_dictionary(&s.dictionary)));
    }
    let report = boot(&net, &config);
    for s in report
        .slaves
        .iter()
        .filter(|s| s.status != SlaveStatus::Operational)
        .take(3)
    {
        eprintln!("{s:?}");
    }
    assert!(
        report
            .slaves
            .iter()
            .all(|s| s.status == SlaveStatus::Operational)
    );
    let parallel = report.elapsed;
    let stats = b.stats();

    // One after another: each slave booted alone on the same bus model.
    let b = bus();
    let net = Network::new(b.endpoint());
    for s in &config.slaves {
        b.attach(SimDevice::new(s.node_id, factory_dictionary(&s.dictionary)));
    }
    let mut serial = canola::Duration::ZERO;
    for s in &config.slaves {
        let one = NetworkConfig {
            path: config.path.clone(),
            master: config.master.clone(),
            slaves: vec![s.clone()],
        };
        let r = boot(&net, &one);
        assert_eq!(r.slaves[0].status, SlaveStatus::Operational);
        serial = serial + r.elapsed;
    }

    let ms = |d: canola::Duration| d.as_micros() as f64 / 1000.0;
    println!(
        "boot of {SLAVES} slaves x {OBJECTS} objects, 1 Mbit/s bus model ({} frames)",
        stats.frames
    );
    println!("{:<44} {:>10}", "", "bus time");
    println!(
        "{:<44} {:>7.1} ms",
        "bound: wire busy with the boot's frames",
        ms(stats.busy)
    );
    println!(
        "{:<44} {:>7.1} ms  ({:.2}x the bound)",
        "canola-manager, every slave in parallel",
        ms(parallel),
        ms(parallel) / ms(stats.busy)
    );
    println!(
        "{:<44} {:>7.1} ms  ({:.2}x the bound)",
        "one slave after another (serial loop model)",
        ms(serial),
        ms(serial) / ms(stats.busy)
    );
}
