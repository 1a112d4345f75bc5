//! Test fixtures: an in-memory object dictionary and a client wired to a server on a virtual
//! clock.
#![allow(dead_code, unreachable_pub)]

use std::collections::BTreeMap;

use canola_frame::{Duration, Instant};
use canola_sdo::{
    AbortCode, Access, Client, ClientConfig, Event, LengthRule, Multiplexer, ObjectAccess,
    ObjectInfo, Server, ServerConfig,
};

pub type TestClient = Client<Vec<u8>, Vec<u8>>;

#[derive(Debug, Clone)]
pub struct Object {
    pub access: Access,
    pub value: Vec<u8>,
    pub rule: LengthRule,
}

/// Objects in a map; downloads are staged and only stored on commit.
#[derive(Debug, Default)]
pub struct MemOd {
    pub objects: BTreeMap<(u16, u8), Object>,
    staging: Vec<u8>,
    pub commits: usize,
    pub discards: usize,
}

pub const U32_RW: Multiplexer = Multiplexer::new(0x2000, 1);
pub const U16_RW: Multiplexer = Multiplexer::new(0x2000, 2);
pub const RO: Multiplexer = Multiplexer::new(0x1000, 0);
pub const WO: Multiplexer = Multiplexer::new(0x2001, 0);
pub const DOMAIN: Multiplexer = Multiplexer::new(0x2100, 0);
pub const LIMITED: Multiplexer = Multiplexer::new(0x2002, 0);
pub const SMALL_STR: Multiplexer = Multiplexer::new(0x2003, 0);
/// Claims to be 7 bytes longer than its value.
pub const LIAR: Multiplexer = Multiplexer::new(0x2004, 0);

impl MemOd {
    pub fn new() -> Self {
        let mut od = Self::default();
        od.insert(
            U32_RW,
            Access::ReadWrite,
            vec![1, 2, 3, 4],
            LengthRule::Exact(4),
        );
        od.insert(
            U16_RW,
            Access::ReadWrite,
            vec![0xE8, 0x03],
            LengthRule::Exact(2),
        );
        od.insert(
            RO,
            Access::ReadOnly,
            vec![0x91, 0x01, 0x02, 0x00],
            LengthRule::Exact(4),
        );
        od.insert(WO, Access::WriteOnly, vec![0], LengthRule::Exact(1));
        od.insert(
            DOMAIN,
            Access::ReadWrite,
            Vec::new(),
            LengthRule::UpTo(1 << 20),
        );
        od.insert(LIMITED, Access::ReadWrite, vec![0], LengthRule::Exact(1));
        od.insert(
            SMALL_STR,
            Access::ReadWrite,
            b"abc".to_vec(),
            LengthRule::UpTo(10),
        );
        od.insert(
            LIAR,
            Access::ReadOnly,
            b"abc".to_vec(),
            LengthRule::UpTo(10),
        );
        od
    }

    pub fn insert(&mut self, mux: Multiplexer, access: Access, value: Vec<u8>, rule: LengthRule) {
        self.objects.insert(
            (mux.index, mux.subindex),
            Object {
                access,
                value,
                rule,
            },
        );
    }

    pub fn value(&self, mux: Multiplexer) -> &[u8] {
        &self.objects[&(mux.index, mux.subindex)].value
    }

    pub fn set(&mut self, mux: Multiplexer, value: Vec<u8>) {
        self.objects
            .get_mut(&(mux.index, mux.subindex))
            .unwrap()
            .value = value;
    }

    fn get(&self, mux: Multiplexer) -> Result<&Object, AbortCode> {
        if let Some(obj) = self.objects.get(&(mux.index, mux.subindex)) {
            return Ok(obj);
        }
        if self.objects.keys().any(|(i, _)| *i == mux.index) {
            Err(AbortCode::SUBINDEX_DOES_NOT_EXIST)
        } else {
            Err(AbortCode::OBJECT_DOES_NOT_EXIST)
        }
    }
}

impl ObjectAccess for MemOd {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        let obj = self.get(mux)?;
        let info = ObjectInfo {
            access: obj.access,
            len: obj.value.len() as u32 + if mux == LIAR { 7 } else { 0 },
            accepts: obj.rule,
        };
        self.staging.clear();
        Ok(info)
    }

    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let value = &self.get(mux)?.value;
        let start = (offset as usize).min(value.len());
        let n = buf.len().min(value.len() - start);
        buf[..n].copy_from_slice(&value[start..start + n]);
        Ok(n)
    }

    fn write(&mut self, mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        self.get(mux)?;
        assert_eq!(
            offset as usize,
            self.staging.len(),
            "writes arrive in order"
        );
        self.staging.extend_from_slice(data);
        Ok(())
    }

    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode> {
        assert_eq!(len as usize, self.staging.len());
        if mux == LIMITED && self.staging[0] > 100 {
            return Err(AbortCode::VALUE_TOO_HIGH);
        }
        let value = std::mem::take(&mut self.staging);
        self.objects
            .get_mut(&(mux.index, mux.subindex))
            .unwrap()
            .value = value;
        self.commits += 1;
        Ok(())
    }

    fn discard(&mut self, _mux: Multiplexer) {
        self.staging.clear();
        self.discards += 1;
    }
}

/// Who sent a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum From {
    Client,
    Server,
}

/// A client and a server on a virtual clock, frames passed in order.
pub struct Pair {
    pub client: TestClient,
    pub server: Server,
    pub od: MemOd,
    pub now: Instant,
    pub log: Vec<(From, [u8; 8])>,
}

impl Pair {
    pub fn new() -> Self {
        Self::with(ClientConfig::default(), ServerConfig::default())
    }

    pub fn with(client: ClientConfig, server: ServerConfig) -> Self {
        Self {
            client: Client::new(client),
            server: Server::new(server),
            od: MemOd::new(),
            now: Instant::ZERO,
            log: Vec::new(),
        }
    }

    /// Moves frames both ways until nothing moves; returns whether any did.
    pub fn pump(&mut self) -> bool {
        let mut moved = false;
        loop {
            let mut any = false;
            while let Some(f) = self.client.poll_transmit() {
                self.log.push((From::Client, f));
                self.server.handle_request(self.now, &f, &mut self.od);
                any = true;
            }
            while let Some(f) = self.server.poll_transmit() {
                self.log.push((From::Server, f));
                self.client.handle_response(self.now, &f);
                any = true;
            }
            if !any {
                return moved;
            }
            moved = true;
            self.now += Duration::from_micros(100);
        }
    }

    /// Runs until the client reports the end of its transfer, advancing the clock to the
    /// next deadline whenever nothing moves.
    pub fn run(&mut self) -> Event<Vec<u8>, Vec<u8>> {
        for _ in 0..100_000 {
            self.pump();
            if let Some(ev) = self.client.poll_event() {
                // Let the last frames (an abort, the end response) reach the server.
                self.pump();
                return ev;
            }
            let next = [self.client.poll_timeout(), self.server.poll_timeout()]
                .into_iter()
                .flatten()
                .min()
                .expect("something must be pending");
            self.now = self.now.max(next);
            self.client.handle_timeout(self.now);
            self.server.handle_timeout(self.now, &mut self.od);
        }
        panic!("transfer did not end");
    }

    pub fn frames(&self, from: From) -> Vec<[u8; 8]> {
        self.log
            .iter()
            .filter(|(f, _)| *f == from)
            .map(|(_, b)| *b)
            .collect()
    }
}
