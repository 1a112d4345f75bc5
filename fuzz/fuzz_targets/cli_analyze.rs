//! The analyzer of `canopen analyze` on any input: every line is a frame or a bad-line problem
//! with its number, never a panic, and what it keeps stays bounded.
#![no_main]

use canola::BusDictionary;
use canola::candump::{ReadError, Reader};
use libfuzzer_sys::fuzz_target;

// The analyzer itself, the file the binary compiles (it depends on canola and canola-cia402).
#[allow(dead_code)]
#[path = "../../crates/cli/src/analyze/judge/mod.rs"]
mod judge;

fuzz_target!(|data: &[u8]| {
    // The first byte picks the bit rate (10 kbit/s .. 1 Mbit/s) for the load arithmetic.
    let (bitrate, log) = match data.split_first() {
        Some((b, rest)) => (10_000 + u32::from(*b) * 3_900, rest),
        None => (500_000, data),
    };
    let mut a = judge::Analyzer::new(judge::Config {
        bitrate,
        load_threshold: 70.0,
        sdo_timeout_us: 500_000,
        dictionary: BusDictionary::new(),
    });
    let mut reader = Reader::new(log);
    let mut bad = 0u64;
    while let Some(entry) = reader.next() {
        match entry {
            Ok(e) => a.frame(reader.line(), e.timestamp_us, &e.frame),
            Err(ReadError::Line { line, error }) => {
                bad += 1;
                a.bad_line(line, format!("line {line}: {error}"));
            }
            Err(e) => panic!("reading a byte slice failed: {e}"),
        }
    }
    a.finish();
    assert_eq!(a.bad_lines, bad);
    assert!(a.problems.len() <= judge::MAX_ENTRIES);
    assert!(a.timeline.len() <= judge::MAX_ENTRIES);
    assert!(a.problems.windows(2).all(|w| w[0].time_us <= w[1].time_us));
    assert!(a.load_mean().is_finite() && a.load_peak.is_finite());
});
