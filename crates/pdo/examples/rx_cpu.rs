//! The benchmark's hot loop without criterion, for measuring CPU time per frame with a counter
//! tool on a busy machine (wall-clock benchmarks include time the thread spent preempted):
//!
//! ```text
//! cargo build --release -p canola-pdo --example rx_cpu
//! perf stat -e task-clock target/release/examples/rx_cpu 20000000
//! ```
//!
//! CPU per frame = task-clock / frames. The loop is the one of `benches/rx_decode.rs`: a
//! four-UNSIGNED16 TPDO received through the engine, its `Received` event consumed and the four
//! typed values handed to a callback.

use std::hint::black_box;

use canola_frame::{CanFrame, CanId, Instant};
use canola_pdo::{CommParams, Engine, Event, Mapping, NullStore, PdoConfig, RawValue};

fn main() {
    let frames_to_run: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000);
    let mut e: Engine<4, 0> = Engine::new();
    for n in 0..4u16 {
        let mapping = Mapping::from_raw(&[0x6401_0110, 0x6401_0210, 0x6401_0310, 0x6401_0410])
            .expect("valid mapping");
        e.add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x185 + 0x100 * n),
            mapping,
        ))
        .expect("room for four PDOs");
    }
    let id = CanId::standard(0x485).expect("valid id");
    let frames = [
        CanFrame::new(id, &[1, 0, 2, 0, 3, 0, 4, 0]).expect("8 bytes"),
        CanFrame::new(id, &[1, 0, 2, 0, 9, 0, 4, 0]).expect("8 bytes"),
    ];
    let mut store = NullStore;
    let mut sum = 0u64;
    let mut callback = |v: RawValue| {
        if let RawValue::Unsigned(x) = v {
            sum = sum.wrapping_add(x);
        }
    };
    let started = std::time::Instant::now();
    for i in 0..frames_to_run {
        let k = (i & 1) as usize;
        e.handle_frame(Instant::from_micros(i), black_box(&frames[k]), &mut store);
        while let Some(ev) = e.poll_event() {
            if let Event::Received { pdo, changed } = ev {
                black_box(changed);
                if let Some(data) = e.received(pdo) {
                    for (_, v) in data.iter() {
                        callback(v);
                    }
                }
            }
        }
    }
    let wall = started.elapsed();
    println!(
        "{frames_to_run} frames, checksum {sum}, wall {:.1} ns/frame",
        wall.as_nanos() as f64 / frames_to_run as f64
    );
}
