//! `canopen demo`: no hardware, no flags. Simulated devices on the in-memory bus (virtual clock),
//! and the master walks through what a commissioning engineer does.

use std::process::ExitCode;

use canola::lss::{AssignConfig, LssAddress, NodeIdPool};
use canola::mem::MemoryBus;
use canola::pdo::{CommParams, Direction, Mapping};
use canola::transport::{Received, Transport};
use canola::{
    BusDictionary, CommandSpecifier, Duration, HeartbeatEvent, Monitor, Network, NetworkEvent,
    NodeId, SimDevice,
};

use crate::outln;

const BURKERT_EDS: &[u8] = canola_burkert::GENERIC_EDS.as_bytes();

fn step(title: &str) {
    outln("");
    outln(&format!("== {title}"));
}

/// Shows the first `max` frames the tap received since the last call. The frames not shown
/// still go through the monitor: it follows SDO block transfers across frames, and a transfer
/// left half-seen would make it read the next section's frames as block segments.
fn show_traffic(tap: &mut canola::Endpoint, monitor: &mut Monitor, max: usize) {
    let mut shown = 0;
    let mut skipped = 0;
    while let Ok(Some(Received::Frame { frame, at })) = tap.try_recv() {
        if shown < max {
            outln(&format!("   {at}  {}", monitor.describe(&frame)));
            shown += 1;
        } else {
            monitor.observe(&frame);
            skipped += 1;
        }
    }
    if skipped > 0 {
        outln(&format!("   ... and {skipped} more frames"));
    }
}

/// Runs the walkthrough.
pub(crate) fn run() -> ExitCode {
    match walk() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => crate::bus::fail(crate::error::CliError::Demo(e)),
    }
}

fn walk() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let n5 = NodeId::new(5)?;
    let n6 = NodeId::new(6)?;
    let od = canola::od::parse(BURKERT_EDS)?.od;
    let n7 = NodeId::new(7)?;
    let mut monitor = Monitor::new(
        BusDictionary::new()
            .with_node(n5, od.clone())
            .with_node(n6, od.clone())
            .with_node(n7, od.clone()),
    );

    outln("canopen demo: a master and two simulated Bürkert devices (eds/burkert-generic.eds)");
    outln("on an in-memory CAN bus (virtual clock, 500 kbit/s timing model). Every frame below");
    outln("really went over it; times are bus time in seconds.");

    // 500 kbit/s with worst-case bit stuffing: transfers take their real on-wire time.
    let bus = MemoryBus::with_config(canola::BusConfig {
        bitrate: Some(500_000),
        worst_case_stuffing: true,
        ..canola::BusConfig::default()
    });
    let mut tap = bus.endpoint();
    let net = Network::new(bus.endpoint());
    let events = net.subscribe();
    net.add_node_with_dictionary(n5, od.clone());
    net.add_node_with_dictionary(n6, od.clone());

    step("1. Power-on: the devices boot and send their boot-up messages");
    let mut logbook_dev = SimDevice::new(n5, od.clone());
    let log: String = (1..=60)
        .map(|i| {
            format!(
                "<entry time=\"{i}\" code=\"0x{:04X}\">valve cycle ok</entry>\n",
                0x1000 + i
            )
        })
        .collect();
    let log = format!("<?xml version=\"1.0\"?>\n<logbook>\n{log}</logbook>\n");
    logbook_dev
        .values_mut()
        .set(0x2003, 4, log.as_bytes().to_vec());
    let dev5 = bus.attach(logbook_dev);
    // Node 6 is the Bürkert-profile device (canola-burkert's simulator: NE 107 status,
    // locating function, logbook) on top of the generic simulator.
    let dev6 = bus.attach(canola_burkert::BurkertDevice::with_dictionary(
        n6,
        od.clone(),
    ));
    net.run_for(Duration::from_millis(10)).wait()?;
    show_traffic(&mut tap, &mut monitor, 10);
    for ev in events.try_iter() {
        if let NetworkEvent::Heartbeat(HeartbeatEvent::BootUp { node }) = ev {
            outln(&format!("   -> node {node} booted (Pre-operational)"));
        }
    }

    step("1b. LSS (CiA 305): an unconfigured device joins; assign-all finds it by Fastscan");
    let addr = LssAddress::new(0x39, 0x0100_0001, 1, 0x0012_3456);
    bus.attach(SimDevice::unconfigured(od.clone(), addr));
    outln(&format!(
        "   an unconfigured device (LSS address {addr}) is powered on: it stays silent"
    ));
    let pool = NodeIdPool::range(n7, n7);
    let report = net.lss().assign_all(AssignConfig::with_pool(pool)).wait()?;
    for e in &report.entries {
        outln(&format!("   assigned {e}"));
    }
    net.run_for(Duration::from_millis(5)).wait()?;
    show_traffic(&mut tap, &mut monitor, 6);
    net.add_node_with_dictionary(n7, od.clone());
    let serial = net.node(n7).sdo().read((0x1018, 4)).wait()?;
    outln(&format!(
        "   node 7 answers SDO: serial number {:#010x}",
        serial
            .get(..4)
            .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    ));

    step("2. Identity (0x1018) of each node, by SDO upload");
    for n in [n5, n6] {
        let sdo = |s: u8| net.node(n).sdo().read((0x1018, s));
        let u = |v: Vec<u8>| {
            v.get(..4)
                .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        outln(&format!(
            "   node {n}: vendor-ID {:#010x}, product {:#010x}, revision {:#010x}, serial {:#010x}",
            u(sdo(1).wait()?),
            u(sdo(2).wait()?),
            u(sdo(3).wait()?),
            u(sdo(4).wait()?)
        ));
    }
    let name = net.node(n5).sdo().read((0x1008, 0)).wait()?;
    outln(&format!(
        "   device name (0x1008, a segmented upload): \"{}\"",
        String::from_utf8_lossy(&name)
    ));
    show_traffic(&mut tap, &mut monitor, 6);

    step("3. Heartbeat configuration: producer time 0x1017 = 100 ms, master consumes it");
    for n in [n5, n6] {
        net.node(n).sdo().write((0x1017, 0), 100u16).wait()?;
        net.monitor_heartbeat(n, Duration::from_millis(250));
    }
    outln(&format!(
        "   node 5 0x1017 now reads {} ms",
        net.node(n5).sdo().read_value((0x1017, 0)).wait()?
    ));
    show_traffic(&mut tap, &mut monitor, 4);

    step(
        "3b. PDO mapping: TPDO3 of node 6 := NE 107 status (0x2004:01) + sensor value 1 (0x2500:01), every 500 ms",
    );
    let mapping = Mapping::from_raw(&[0x2004_0108, 0x2500_0120])?;
    let comm = CommParams::event_driven(0x386).with_event_timer(500);
    net.node(n6)
        .remap_pdo(Direction::Transmit, 3, comm, mapping)
        .wait()?;
    outln(
        "   (disable TPDO3, clear mapping, write entries, set count, set parameters, enable: by SDO)",
    );
    show_traffic(&mut tap, &mut monitor, 8);

    step("4. Start: NMT Start to all nodes, heartbeats now say Operational");
    net.nmt_all(CommandSpecifier::Start)?;
    net.run_for(Duration::from_millis(250)).wait()?;
    show_traffic(&mut tap, &mut monitor, 8);
    for n in [n5, n6] {
        let state = net
            .last_state(n)
            .map_or("no state yet".to_string(), |s| s.to_string());
        outln(&format!("   node {n} reports {state}"));
    }

    step(
        "4b. Live PDO values, decoded through each node's EDS mapping; a new reading of node 5 sensor 1 goes out on change",
    );
    for _ in events.try_iter() {}
    net.run_for(Duration::from_millis(700)).wait()?;
    let now = bus.now();
    bus.with_station(dev5, |d| {
        d.set_value(now, 0x2500, 1, 21.75f32.to_le_bytes())
    });
    net.run_for(Duration::from_millis(800)).wait()?;
    let mut shown = 0;
    for ev in events.try_iter() {
        if let NetworkEvent::PdoValues {
            node,
            number,
            values,
            at,
            ..
        } = ev
            && shown < 10
        {
            let text: Vec<String> = values.iter().map(|(e, v)| format!("{e} = {v}")).collect();
            outln(&format!(
                "   {at}  node {node} TPDO{number}: {}",
                text.join(", ")
            ));
            shown += 1;
        }
    }
    while let Ok(Some(_)) = tap.try_recv() {}

    step("5. A segmented download: location text into 0x2002:02");
    net.node(n6)
        .sdo()
        .write((0x2002, 2), "Hall 3 / line 7 / valve island A")
        .wait()?;
    let back = net.node(n6).sdo().read((0x2002, 2)).wait()?;
    outln(&format!(
        "   read back: \"{}\"",
        String::from_utf8_lossy(&back)
    ));
    show_traffic(&mut tap, &mut monitor, 12);

    step("6. A block transfer: the logbook DOMAIN 0x2003:04 (XML) with progress");
    let t0 = net.now();
    let data = net
        .node(n5)
        .sdo()
        .block(true)
        .on_progress(|p| {
            if p.total.is_some() && (p.done % 889 < 7 || Some(p.done) == p.total) {
                outln(&format!(
                    "   progress {}/{} bytes",
                    p.done,
                    p.total.unwrap_or(0)
                ));
            }
        })
        .read((0x2003, 4))
        .wait()?;
    outln(&format!(
        "   {} bytes in {} of bus time; first line: {}",
        data.len(),
        net.now() - t0,
        String::from_utf8_lossy(&data).lines().next().unwrap_or("")
    ));
    show_traffic(&mut tap, &mut monitor, 8);

    step("7. An SDO abort, explained: reading an object the device does not have");
    match net.node(n5).sdo().read((0x6000, 1)).wait() {
        Ok(_) => outln("   (unexpectedly answered)"),
        Err(e) => outln(&format!("   {e}")),
    }
    match net.node(n5).sdo().write((0x1018, 1), 0x1234u32).wait() {
        Ok(_) => outln("   (unexpectedly written)"),
        Err(e) => outln(&format!("   {e}")),
    }
    show_traffic(&mut tap, &mut monitor, 4);

    step(
        "7b. Bürkert profile on node 6: NE 107 status (0x2004:01) and the locating function (0x2101:01)",
    );
    bus.with_station(dev6, |d| {
        d.raise(canola_burkert::Ne107Status::MaintenanceRequired)
    });
    let status = net.node(n6).sdo().read((0x2004, 1)).wait()?;
    let raw = status.first().copied().unwrap_or(0);
    let meaning = canola_burkert::Ne107Status::from_u8(raw & 0x0F).meaning_en();
    outln(&format!(
        "   the device raised an event; 0x2004:01 reads {raw} = {meaning}"
    ));
    net.node(n6).sdo().write((0x2101, 1), 1u8).wait()?;
    outln(&format!(
        "   wrote 0x2101:01 = 1: the device is locating (LED flashing): {}",
        bus.with_station(dev6, |d| d.locating()).unwrap_or(false)
    ));
    net.node(n6).sdo().write((0x2101, 1), 0u8).wait()?;
    show_traffic(&mut tap, &mut monitor, 4);
    // The Bürkert view of the same device (canola_burkert::BurkertNode): the whole status in
    // one batch of SDO reads with the LED drawn, a locate (honouring "0 before 1"), and the
    // logbook by block transfer with a progress bar.
    outln("   BurkertNode walkthrough:");
    let options = canola_burkert::demo::Options {
        ansi: std::io::IsTerminal::is_terminal(&std::io::stdout()),
        block: true,
    };
    let mut text = Vec::new();
    let walk = canola_burkert::demo::run_with(&net, n6, &mut text, options);
    for line in String::from_utf8_lossy(&text).lines() {
        outln(&format!("   {line}"));
    }
    walk?;
    show_traffic(&mut tap, &mut monitor, 2);

    step("8. NMT Stop to node 6: its heartbeat reports Stopped");
    net.node(n6).nmt().stop()?;
    net.run_for(Duration::from_millis(300)).wait()?;
    for ev in events.try_iter() {
        if let NetworkEvent::Heartbeat(h) = ev {
            outln(&format!("   event: {h}"));
        }
    }

    outln("");
    let _ = tap.now();
    Ok(())
}
