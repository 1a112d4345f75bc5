//! CPU per received TPDO frame, decoded into typed values through the engine: a node's four
//! PDOs configured as receive PDOs, frames for the fourth one (the last in the lookup), each a
//! four-UNSIGNED16 mapping; the consumer takes the `Received` event and reads the four typed
//! values in a callback. python-canopen's figure for the same job is 3.3 µs per frame.
//!
//! Run: `cargo bench -p canola-pdo --bench rx_decode`.

use std::hint::black_box;

use canola_frame::{CanFrame, CanId, Instant};
use canola_pdo::{CommParams, Engine, Event, Mapping, NullStore, PdoConfig, RawValue, unpack};
use criterion::{Criterion, Throughput, criterion_main};

fn engine() -> Engine<4, 0> {
    let mut e = Engine::new();
    for n in 0..4u16 {
        let mapping = Mapping::from_raw(&[0x6401_0110, 0x6401_0210, 0x6401_0310, 0x6401_0410])
            .expect("valid mapping");
        e.add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x185 + 0x100 * n),
            mapping,
        ))
        .expect("room for four PDOs");
    }
    e
}

fn bench(c: &mut Criterion) {
    let id = CanId::standard(0x485).expect("valid id");
    let frames = [
        CanFrame::new(id, &[1, 0, 2, 0, 3, 0, 4, 0]).expect("8 bytes"),
        CanFrame::new(id, &[1, 0, 2, 0, 9, 0, 4, 0]).expect("8 bytes"),
    ];
    let mut g = c.benchmark_group("rx_tpdo_4xu16");
    g.throughput(Throughput::Elements(1));

    g.bench_function("engine_event_callback", |b| {
        let mut e = engine();
        let mut store = NullStore;
        let mut i = 0usize;
        let mut sum = 0u64;
        // The application's callback: gets the PDO's typed values.
        let mut callback = |v: RawValue| {
            if let RawValue::Unsigned(x) = v {
                sum = sum.wrapping_add(x);
            }
        };
        b.iter(|| {
            i ^= 1;
            let now = Instant::from_micros(i as u64);
            e.handle_frame(now, black_box(&frames[i]), &mut store);
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
        });
        black_box(sum);
    });

    g.bench_function("unpack_only", |b| {
        let mapping = Mapping::from_raw(&[0x6401_0110, 0x6401_0210, 0x6401_0310, 0x6401_0410])
            .expect("valid mapping");
        let data = [1u8, 0, 2, 0, 3, 0, 4, 0];
        b.iter(|| {
            let mut sum = 0u64;
            if let Ok(u) = unpack(&mapping, black_box(&data)) {
                for (_, v) in u.iter() {
                    sum = sum.wrapping_add(v.as_u64().unwrap_or(0));
                }
            }
            sum
        });
    });
    g.finish();
}

/// The generated harness functions carry no docs of their own.
mod harness {
    #![allow(missing_docs)]
    use super::bench;
    use criterion::criterion_group;
    criterion_group!(benches, bench);
}

criterion_main!(harness::benches);
