//! Random sequences of commands, server frames and clock steps fed to the SDO client: no
//! panic, bounded output per step, exactly one completion per started transfer, and progress
//! and deadlines that stay consistent.
#![no_main]

use arbitrary::Arbitrary;
use canola_frame::{Duration, Instant};
use canola_sdo::{AbortCode, Client, ClientConfig, Event, Method, Multiplexer, SliceSink};
use libfuzzer_sys::fuzz_target;

#[derive(Debug, Arbitrary)]
enum Op {
    Upload {
        index: u16,
        subindex: u8,
        method: u8,
    },
    Download {
        index: u16,
        subindex: u8,
        method: u8,
        len: u16,
    },
    Frame([u8; 8]),
    ShortFrame(Vec<u8>),
    Advance(u16),
    Timeout,
    Abort(u32),
}

#[derive(Debug, Arbitrary)]
struct Input {
    timeout_ms: u16,
    block_size: u8,
    crc: bool,
    pst: u8,
    ops: Vec<Op>,
}

fn method(m: u8) -> Method {
    match m % 3 {
        0 => Method::Normal,
        1 => Method::Segmented,
        _ => Method::Block,
    }
}

static SOURCE: [u8; 4096] = [0x5A; 4096];

fuzz_target!(|input: Input| {
    let config = ClientConfig::default()
        .with_timeout(Duration::from_millis(u64::from(input.timeout_ms)))
        .with_block_size(input.block_size)
        .with_crc(input.crc)
        .with_protocol_switch_threshold(input.pst);
    let mut sink_buf = [0u8; 1024];
    let mut sink_slot = Some(&mut sink_buf[..]);
    let mut client: Client<SliceSink<'_>, &[u8]> = Client::new(config);
    let mut now = Instant::ZERO;
    let mut running = false;
    for op in input.ops.into_iter().take(2000) {
        match op {
            Op::Upload {
                index,
                subindex,
                method: m,
            } => {
                if let Some(buf) = sink_slot.take() {
                    match client.start_upload(
                        now,
                        Multiplexer::new(index, subindex),
                        SliceSink::new(buf),
                        method(m),
                    ) {
                        Ok(()) => {
                            assert!(!running);
                            running = true;
                        }
                        Err(busy) => {
                            assert!(running);
                            sink_slot = Some(busy.0.into_inner().0);
                        }
                    }
                }
            }
            Op::Download {
                index,
                subindex,
                method: m,
                len,
            } => {
                let data = &SOURCE[..usize::from(len) % SOURCE.len()];
                match client.start_download(now, Multiplexer::new(index, subindex), data, method(m))
                {
                    Ok(()) => {
                        assert!(!running);
                        running = true;
                    }
                    Err(_) => assert!(running || !client.is_idle()),
                }
            }
            Op::Frame(bytes) => client.handle_response(now, &bytes),
            Op::ShortFrame(bytes) => client.handle_response(now, &bytes),
            Op::Advance(ms) => now += Duration::from_millis(u64::from(ms)),
            Op::Timeout => client.handle_timeout(now),
            Op::Abort(code) => {
                let was = client.abort(now, AbortCode(code));
                assert_eq!(was, running);
            }
        }
        // A sub-block is at most 127 segments, plus a few queued single frames.
        let mut frames = 0;
        while client.poll_transmit().is_some() {
            frames += 1;
            assert!(frames <= 132);
        }
        if let Some(progress) = client.progress() {
            assert!(running);
            if let Some(total) = progress.total
                && progress.direction == canola_sdo::Direction::Download
            {
                assert!(progress.done <= total);
            }
            assert!(client.poll_timeout().is_some());
        } else {
            assert_eq!(client.poll_timeout(), None);
        }
        if let Some(event) = client.poll_event() {
            assert!(running);
            running = false;
            match event {
                Event::Uploaded { sink, len, .. } => {
                    assert_eq!(sink.len(), len as usize);
                    sink_slot = Some(sink.into_inner().0);
                }
                Event::Failed {
                    buffer: canola_sdo::Buffer::Sink(sink),
                    error,
                } => {
                    let _ = error.to_string();
                    sink_slot = Some(sink.into_inner().0);
                }
                Event::Failed { error, .. } => {
                    let _ = error.to_string();
                }
                Event::Downloaded { .. } => {}
            }
        }
        assert_eq!(client.is_idle(), !running);
    }
});
