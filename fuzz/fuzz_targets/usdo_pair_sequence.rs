//! A USDO client and server (CiA 1301) back to back on a channel that loses, repeats and
//! reorders frames as the input says: no panic; every started transfer ends with exactly one
//! event; a finished upload holds exactly the object's bytes and a finished download was
//! committed as sent; without faults everything succeeds; both sides end without sessions.
#![no_main]

use std::collections::{BTreeMap, VecDeque};

use arbitrary::Arbitrary;
use canola_frame::{Duration, Instant, NodeId};
use canola_sdo::usdo::{
    DataType, UsdoClient, UsdoClientConfig, UsdoEvent, UsdoServer, UsdoServerConfig,
};
use canola_sdo::{AbortCode, Access, Multiplexer, ObjectAccess, ObjectInfo};
use libfuzzer_sys::fuzz_target;

#[derive(Debug, Arbitrary)]
struct Input {
    /// Lengths of the values read and written (one upload and one download each, at most 4).
    lens: Vec<u16>,
    /// Per frame on the wire: 0 lost, 1 repeated later, 2 swapped with the next, else delivered.
    script: Vec<u8>,
    /// Starts some transfers after others have run for this many frames.
    stagger: u8,
    /// Cancels the transfer with this index, when set, after `stagger` frames.
    cancel: Option<u8>,
}

fn pattern(len: usize, seed: u8) -> Vec<u8> {
    (0..len)
        .map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed))
        .collect()
}

#[derive(Default)]
struct Od {
    values: BTreeMap<u16, Vec<u8>>,
    staged: BTreeMap<u16, Vec<u8>>,
    commits: Vec<(u16, Vec<u8>)>,
}

impl ObjectAccess for Od {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        let v = self
            .values
            .get(&mux.index)
            .ok_or(AbortCode::OBJECT_DOES_NOT_EXIST)?;
        let access = if mux.index >= 0x2200 {
            Access::ReadWrite
        } else {
            Access::ReadOnly
        };
        Ok(ObjectInfo::variable(access, v.len() as u32, 70_000))
    }
    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let v = &self.values[&mux.index];
        let rest = &v[(offset as usize).min(v.len())..];
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }
    fn write(&mut self, mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        let s = self.staged.entry(mux.index).or_default();
        if offset == 0 {
            s.clear();
        }
        assert_eq!(s.len(), offset as usize, "writes arrive in order");
        s.extend_from_slice(data);
        Ok(())
    }
    fn commit(&mut self, mux: Multiplexer, len: u32) -> Result<(), AbortCode> {
        let s = self.staged.remove(&mux.index).unwrap_or_default();
        assert_eq!(s.len(), len as usize);
        self.values.insert(mux.index, s.clone());
        self.commits.push((mux.index, s));
        Ok(())
    }
    fn discard(&mut self, mux: Multiplexer) {
        self.staged.remove(&mux.index);
    }
}

const CLIENT: u8 = 1;
const SERVER: u8 = 5;

fuzz_target!(|input: Input| {
    let lens: Vec<usize> = input
        .lens
        .iter()
        .take(4)
        .map(|l| usize::from(*l % 2000))
        .collect();
    let mut od = Od::default();
    for (i, len) in lens.iter().enumerate() {
        od.values.insert(0x2100 + i as u16, pattern(*len, i as u8));
        od.values.insert(0x2200 + i as u16, Vec::new());
    }
    let server_node = NodeId::new(SERVER).unwrap();
    let mut client: UsdoClient<Vec<u8>, Vec<u8>> =
        UsdoClient::new(NodeId::new(CLIENT).unwrap(), UsdoClientConfig::default());
    let mut server = UsdoServer::new(server_node, UsdoServerConfig::default());
    let mut now = Instant::ZERO;
    let mut script: VecDeque<u8> = input.script.into_iter().take(4000).collect();
    let faults = script.iter().any(|d| d % 8 < 3);
    let mut wire: VecDeque<(bool, Vec<u8>)> = VecDeque::new();
    // (session, upload?, index into lens)
    let mut started: Vec<(u8, bool, usize)> = Vec::new();
    let mut events = Vec::new();
    let mut cancelled = None;
    let start = |client: &mut UsdoClient<Vec<u8>, Vec<u8>>,
                 started: &mut Vec<_>,
                 now,
                 range: std::ops::Range<usize>| {
        for i in range {
            let mux = |base: u16| Multiplexer::new(base + i as u16, 0);
            let up = client
                .start_upload(now, server_node, mux(0x2100), Vec::new())
                .unwrap();
            let down = client
                .start_download(
                    now,
                    server_node,
                    mux(0x2200),
                    DataType::DOMAIN,
                    pattern(lens[i], 100 + i as u8),
                )
                .unwrap();
            started.push((up, true, i));
            started.push((down, false, i));
        }
    };
    let half = lens.len() / 2;
    start(&mut client, &mut started, now, 0..half);
    let mut frames = 0usize;
    let mut later = true;
    for _ in 0..200_000 {
        if later && frames >= usize::from(input.stagger) {
            later = false;
            start(&mut client, &mut started, now, half..lens.len());
            if let Some(c) = input.cancel
                && let Some(&(session, _, _)) = started.get(usize::from(c) % started.len().max(1))
                && client.abort(server_node, session)
            {
                cancelled = Some(session);
            }
        }
        while let Some(f) = client.poll_transmit_frame() {
            wire.push_back((true, f.data().to_vec()));
        }
        while let Some(f) = server.poll_transmit_frame() {
            wire.push_back((false, f.data().to_vec()));
        }
        while let Some(e) = client.poll_event() {
            events.push(e);
        }
        let Some((to_server, data)) = wire.pop_front() else {
            if later {
                frames = usize::MAX;
                continue;
            }
            let next = [client.poll_timeout(), server.poll_timeout()]
                .into_iter()
                .flatten()
                .min();
            let Some(at) = next else { break };
            now = now.max(at);
            client.handle_timeout(now);
            server.handle_timeout(now, &mut od);
            continue;
        };
        let mut deliver = |to_server: bool, data: &[u8], now: &mut Instant, od: &mut Od| {
            frames = frames.saturating_add(1);
            *now += Duration::from_micros(150);
            if to_server {
                server.handle_request(*now, CLIENT, data, od);
            } else {
                client.handle_response(*now, SERVER, data);
            }
        };
        match script.pop_front().map(|d| d % 8) {
            Some(0) => {}
            Some(1) => {
                deliver(to_server, &data, &mut now, &mut od);
                wire.push_back((to_server, data));
            }
            Some(2) if !wire.is_empty() => wire.insert(1, (to_server, data)),
            _ => deliver(to_server, &data, &mut now, &mut od),
        }
    }
    assert!(
        wire.is_empty() && client.is_idle(),
        "the pair did not settle"
    );
    assert_eq!(server.sessions(), 0);
    assert_eq!(events.len(), started.len(), "one event per transfer");
    for e in events {
        match e {
            UsdoEvent::Uploaded { session, sink, .. } => {
                let &(_, up, i) = started.iter().find(|s| s.0 == session).unwrap();
                assert!(up);
                assert_eq!(sink, pattern(lens[i], i as u8));
            }
            UsdoEvent::Downloaded {
                session,
                mux,
                source,
                ..
            } => {
                assert!(started.iter().any(|s| s.0 == session && !s.1));
                assert!(od.commits.contains(&(mux.index, source)));
            }
            UsdoEvent::Failed { error, .. } => {
                assert!(faults || cancelled == Some(error.session), "{error}");
            }
        }
    }
    for (index, value) in &od.commits {
        let i = usize::from(index - 0x2200);
        assert_eq!(value, &pattern(lens[i], 100 + i as u8));
    }
});
