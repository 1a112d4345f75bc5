//! The slcan line decoder and command parser: never panic on any bytes, in any chunking; every
//! frame they accept encodes to a line that decodes to the same frame; the decoder's counters add
//! up to what it returned. `-max_len=1024` (fuzz/options): inputs longer than a line
//! (`MAX_LINE` = 160) reach the overlong-line path, and several lines per input the
//! resynchronisation.
#![no_main]

use canola_slcan::{Command, Decoder, Item, MAX_COMMAND, MAX_LINE};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first byte picks a chunk size, so lines are split at varying places.
    let Some((&chunk, bytes)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(chunk).max(1);
    let mut d = Decoder::new();
    let mut returned = 0u64;
    for part in bytes.chunks(chunk) {
        for item in d.feed(part) {
            returned += 1;
            if let Ok(Item::Frame(rx)) = item {
                let mut buf = [0u8; MAX_LINE + 1];
                let n = rx.encode(&mut buf).expect("a decoded frame fits a line");
                let again: Vec<_> = Decoder::new().feed(&buf[..n]).collect();
                assert_eq!(again, [Ok(Item::Frame(rx))]);
            }
        }
    }
    assert_eq!(returned, d.items() + d.errors());
    // The same bytes as host-to-adapter command lines.
    for line in bytes.split(|&b| b == b'\r') {
        if let Ok(cmd) = Command::parse(line) {
            let mut buf = [0u8; MAX_COMMAND];
            let n = cmd.encode(&mut buf).expect("a parsed command fits");
            assert_eq!(Command::parse(&buf[..n - 1]), Ok(cmd));
        }
    }
});
