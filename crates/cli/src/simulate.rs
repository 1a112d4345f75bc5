//! `canopen simulate EDS --node-id N`: a simulated device ([`canola_burkert::SimulatedDevice`]:
//! the Bürkert device for a file with the Bürkert profile, the simulated servo of
//! `canola-cia402` for a CiA 402 drive, the generic simulator otherwise) on
//! SocketCAN until stopped, or on the in-memory bus for `--duration` seconds of bus time,
//! printing the traffic.

use std::path::Path;
use std::process::ExitCode;

use canola::transport::{Received, Transport as _};
use canola::{BusDictionary, Monitor, NodeId, Station};
use serde_json::json;

use crate::bus::{Bus, BusOpts, fail, read_dictionary, seconds};
use crate::error::CliError;
use crate::{Global, outln};

/// `canopen simulate EDS --node-id N`
pub(crate) fn run(
    opts: &BusOpts,
    eds: &Path,
    node: NodeId,
    duration: Option<f64>,
    g: Global,
) -> ExitCode {
    let od = match read_dictionary(eds) {
        Ok(od) => od,
        Err(e) => return fail(e),
    };
    let bus = match opts.open() {
        Ok(b) => b,
        Err(e) => return fail(e),
    };
    // Refused before anything is said to run.
    if bus.memory.is_some() && duration.is_none() {
        return fail(needs_duration());
    }
    eprintln!("simulating node {node} from {}", eds.display());
    let dictionary = BusDictionary::new().with_node(node, od.clone());
    let mut device = crate::sim_device::simulated_device(node, od);
    // `--fd`: a CANopen FD device, serving USDO on the CAN FD bus.
    if opts.fd {
        device.set_fd(true);
    }
    run_station(bus, device, &dictionary, duration, g)
}

/// A run on the in-memory bus without `--duration` (a usage error).
fn needs_duration() -> CliError {
    CliError::usage(
        "on the in-memory bus give --duration SECONDS (it runs on bus time, not until stopped)",
    )
}

/// Runs `station` on the bus: on SocketCAN until `duration` (or forever), on the in-memory bus
/// for `duration` of bus time, then prints the traffic described with `dictionary`.
pub(crate) fn run_station(
    mut bus: Bus,
    station: impl Station + 'static,
    dictionary: &BusDictionary,
    duration: Option<f64>,
    g: Global,
) -> ExitCode {
    if let Some(mem) = bus.memory.as_ref() {
        let Some(secs) = duration else {
            return fail(needs_duration());
        };
        let mut tap = mem.endpoint();
        let mut monitor = Monitor::new(dictionary.clone());
        mem.attach(station);
        mem.run_for(seconds(secs));
        while let Ok(Some(Received::Frame { frame, at })) = tap.try_recv() {
            if g.json {
                outln(
                    &json!({"time": at.as_micros() as f64 / 1e6, "frame": frame.to_string()})
                        .to_string(),
                );
            } else {
                outln(&format!("{at}  {}", monitor.describe(&frame)));
            }
        }
        return ExitCode::SUCCESS;
    }
    let mut station = station;
    let started = std::time::Instant::now();
    let limit = duration.map(std::time::Duration::from_secs_f64);
    let r = canola::run_station(&mut bus.transport, &mut station, || {
        limit.is_some_and(|l| started.elapsed() >= l)
    });
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(e),
    }
}
