//! The speed of `canopen analyze` on a long log at full bus load, beside candump-format
//! parsing alone (the floor under it: the same reader, no analysis).
//!
//! `analyze_log generate FILE SECONDS` writes a log of a 1 Mbit/s bus at about 95 % load for
//! SECONDS of bus time: 32 nodes with a 100 ms heartbeat, a 1 kHz SYNC, each node's TPDO1 and
//! TPDO2 every millisecond-ish (8 bytes), an SDO read now and then, an EMCY (and its reset
//! 100 ms later) every 10 s, all in candump's `-l` format. `generate FILE 3600` is the hour of
//! issue 42 (33.7 M frames, 1.48 GB). `analyze_log parse FILE` reads it with
//! `canola::candump::Reader` only; `analyze_log analyze FILE` reads it and runs the analyzer of
//! `canopen analyze` (its file compiled in) over it. Each prints frames, seconds, frames/s and
//! the process's peak RSS (`getrusage`), so each mode is measured in a process of its own.

use std::io::{BufRead, BufReader, BufWriter, Write};
use std::time::Instant;

use canola::BusDictionary;
use canola::candump::{LogEntry, LogFrame, ReadError, Reader, Writer};
use canola::{CanFrame, CanId};

#[allow(dead_code)]
#[path = "../../../cli/src/analyze/judge/mod.rs"]
mod judge;

fn usage() -> ! {
    eprintln!("usage: analyze_log generate FILE SECONDS | parse FILE | analyze FILE");
    std::process::exit(2)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["generate", file, secs] => generate(file, secs.parse().unwrap_or_else(|_| usage())),
        ["parse", file] => measure("parse", file, |_, _, _| {}, |_| {}),
        ["analyze", file] => {
            let a = std::cell::RefCell::new(judge::Analyzer::new(judge::Config {
                bitrate: 1_000_000,
                load_threshold: 99.0,
                sdo_timeout_us: 500_000,
                dictionary: BusDictionary::new(),
            }));
            measure(
                "analyze",
                file,
                |line, t, f| a.borrow_mut().frame(line, t, f),
                |line| a.borrow_mut().bad_line(line, String::new()),
            );
            let mut a = a.into_inner();
            a.finish();
            println!(
                "problems {}, timeline {}, mean load {:.1} %",
                a.problems.len(),
                a.timeline.len(),
                a.load_mean()
            );
        }
        _ => usage(),
    }
}

fn frame(id: u16, data: &[u8]) -> LogFrame {
    LogFrame::Can(CanFrame::new(CanId::standard(id).expect("11-bit"), data).expect("8 bytes"))
}

/// A 1 Mbit/s bus near full load: 8-byte frames take about 111 bits without stuffing, so
/// 8 500 frames a second fill it to about 95 %.
fn generate(file: &str, seconds: u64) {
    let out = std::fs::File::create(file).expect("create the log");
    let mut w = Writer::new(BufWriter::with_capacity(1 << 20, out));
    let mut frames = 0u64;
    let base = 1_700_000_000_000_000u64;
    for ms in 0..seconds * 1000 {
        let t = base + ms * 1000;
        let mut put = |offset: u64, f: LogFrame| {
            w.write(&LogEntry {
                timestamp_us: t + offset,
                interface: "can0".into(),
                frame: f,
                len8_dlc: None,
            })
            .expect("write the log");
            frames += 1;
        };
        put(0, frame(0x080, &[]));
        // Eight PDOs a millisecond, rotating over 32 nodes' TPDO1 and TPDO2.
        for k in 0..8u64 {
            let slot = (ms * 8 + k) % 64;
            let node = (slot / 2 + 1) as u16;
            let id = if slot % 2 == 0 { 0x180 } else { 0x280 } + node;
            let v = (ms as u32).wrapping_mul(2_654_435_761).to_le_bytes();
            put(
                10 + k * 111,
                frame(id, &[v[0], v[1], v[2], v[3], k as u8, 0, 0, 0]),
            );
        }
        // Heartbeats: node ms % 100 + 1 (of 32) every 100 ms.
        if ms % 100 < 32 {
            put(950, frame(0x701 + (ms % 100) as u16, &[0x05]));
        }
        // An EMCY every 10 s (generic error, error register 0x01) from node 1, 2, ..., and its
        // error reset 100 ms later.
        if ms % 10_000 == 5_000 || ms % 10_000 == 5_100 {
            let node = (ms / 10_000 % 32 + 1) as u16;
            let data = if ms % 10_000 == 5_000 {
                [0x00, 0x10, 0x01, 0, 0, 0, 0, 0]
            } else {
                [0; 8]
            };
            put(990, frame(0x080 + node, &data));
        }
        // An SDO read of 0x1018:01 and its answer every 50 ms.
        if ms % 50 == 0 {
            let node = (ms / 50 % 32 + 1) as u16;
            put(
                960,
                frame(0x600 + node, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]),
            );
            put(
                980,
                frame(0x580 + node, &[0x43, 0x18, 0x10, 0x01, 0x79, 0, 0, 0]),
            );
        }
    }
    w.flush().expect("flush the log");
    println!("{frames} frames, {seconds} s of bus time, written to {file}");
}

/// Reads `file` and hands each frame to `on_frame`, each bad line to `on_bad`; prints the
/// figures.
fn measure(
    what: &str,
    file: &str,
    mut on_frame: impl FnMut(usize, u64, &LogFrame),
    mut on_bad: impl FnMut(usize),
) {
    let f = std::fs::File::open(file).expect("open the log");
    let input: Box<dyn BufRead> = Box::new(BufReader::with_capacity(1 << 16, f));
    let start = Instant::now();
    let mut reader = Reader::new(input);
    let mut frames = 0u64;
    while let Some(entry) = reader.next() {
        match entry {
            Ok(e) => {
                frames += 1;
                on_frame(reader.line(), e.timestamp_us, &e.frame);
            }
            Err(ReadError::Line { line, .. }) => on_bad(line),
            Err(e) => panic!("{e}"),
        }
    }
    let secs = start.elapsed().as_secs_f64();
    let rss_kib = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_SELF)
        .map_or(0, |u| u.max_rss());
    let _ = std::io::stdout().flush();
    println!(
        "{what}: {frames} frames in {secs:.2} s = {:.0} frames/s, peak RSS {} MiB",
        frames as f64 / secs,
        rss_kib / 1024
    );
}
