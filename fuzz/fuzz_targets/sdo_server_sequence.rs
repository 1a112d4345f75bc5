//! Random client frames and clock steps fed to the SDO server over a small object dictionary:
//! no panic, bounded output per step, and a state that stays consistent (a deadline exactly
//! while a transfer runs; writes arrive in order and are committed or discarded).
#![no_main]

use arbitrary::Arbitrary;
use canola_frame::{Duration, Instant};
use canola_sdo::{AbortCode, Access, Multiplexer, ObjectAccess, ObjectInfo, Server, ServerConfig};
use libfuzzer_sys::fuzz_target;

#[derive(Debug, Arbitrary)]
enum Op {
    Frame([u8; 8]),
    ShortFrame(Vec<u8>),
    Advance(u16),
    Timeout,
}

#[derive(Debug, Arbitrary)]
struct Input {
    timeout_ms: u16,
    block_size: u8,
    crc: bool,
    ops: Vec<Op>,
}

/// Objects at index 0x2000: sub 0 a 2 KiB DOMAIN, sub 1 a u32, sub 2 read-only, sub 3
/// write-only. Writes are staged in a fixed buffer.
struct Od {
    domain: [u8; 2048],
    domain_len: u32,
    staged: u32,
    writing: Option<Multiplexer>,
}

impl ObjectAccess for Od {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        if mux.index != 0x2000 {
            return Err(AbortCode::OBJECT_DOES_NOT_EXIST);
        }
        self.staged = 0;
        self.writing = None;
        match mux.subindex {
            0 => Ok(ObjectInfo::variable(
                Access::ReadWrite,
                self.domain_len,
                2048,
            )),
            1 => Ok(ObjectInfo::fixed(Access::ReadWrite, 4)),
            2 => Ok(ObjectInfo::fixed(Access::Const, 2)),
            3 => Ok(ObjectInfo::fixed(Access::WriteOnly, 1)),
            _ => Err(AbortCode::SUBINDEX_DOES_NOT_EXIST),
        }
    }

    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let len = match mux.subindex {
            0 => self.domain_len,
            1 => 4,
            _ => 2,
        };
        assert!(offset <= len);
        let n = buf.len().min((len - offset) as usize);
        buf[..n].fill(0xA5);
        Ok(n)
    }

    fn write(&mut self, mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        if let Some(w) = self.writing {
            assert_eq!(w, mux);
        }
        self.writing = Some(mux);
        assert_eq!(offset, self.staged, "writes arrive in order");
        self.staged += data.len() as u32;
        assert!(self.staged <= 2048);
        Ok(())
    }

    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode> {
        assert_eq!(len, self.staged);
        if mux.subindex == 0 {
            self.domain_len = len;
        }
        self.staged = 0;
        self.writing = None;
        Ok(())
    }

    fn discard(&mut self, _mux: Multiplexer) {
        self.staged = 0;
        self.writing = None;
    }
}

fuzz_target!(|input: Input| {
    let mut server = Server::new(ServerConfig {
        timeout: Duration::from_millis(u64::from(input.timeout_ms)),
        block_size: input.block_size,
        crc: input.crc,
    });
    let mut od = Od {
        domain: [0; 2048],
        domain_len: 100,
        staged: 0,
        writing: None,
    };
    let _ = od.domain;
    let mut now = Instant::ZERO;
    for op in input.ops.into_iter().take(2000) {
        match op {
            Op::Frame(bytes) => server.handle_request(now, &bytes, &mut od),
            Op::ShortFrame(bytes) => server.handle_request(now, &bytes, &mut od),
            Op::Advance(ms) => now += Duration::from_millis(u64::from(ms)),
            Op::Timeout => server.handle_timeout(now, &mut od),
        }
        let mut frames = 0;
        while server.poll_transmit().is_some() {
            frames += 1;
            assert!(frames <= 132);
        }
        while server.poll_event().is_some() {}
        assert_eq!(server.is_idle(), server.poll_timeout().is_none());
        assert_eq!(server.is_idle(), server.current().is_none());
    }
});
