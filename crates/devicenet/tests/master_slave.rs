//! The master machine against the slave machine on a virtual bus: every frame one sends reaches
//! the other (and a third station, when there is one), time advances in 1 ms steps.

use canola_devicenet::explicit::Path;
use canola_devicenet::fragment::MessageBuf;
use canola_devicenet::master::{ConnectError, ExplicitFailure};
use canola_devicenet::slave::{Connection, ConnectionState, NetworkState};
use canola_devicenet::{
    Application, CipError, GeneralStatus, Identity, MacId, Master, MasterConfig, MasterEvent,
    MasterState, Slave, SlaveConfig, SlaveEvent,
};
use canola_frame::{CanFrame, CanId, Duration, Instant, is_due};

#[derive(Debug, Default)]
struct Echo {
    consumed: Vec<Vec<u8>>,
    idles: usize,
    timed_out: usize,
    value: u8,
}

impl Application for Echo {
    fn consume(&mut self, _now: Instant, data: &[u8]) {
        self.consumed.push(data.to_vec());
    }
    fn produce(&mut self, _now: Instant, out: &mut MessageBuf) {
        // The response is the last command reversed (so both directions carry distinct data).
        let mut last = self.consumed.last().cloned().unwrap_or_default();
        last.reverse();
        out.extend_from_slice(&last).unwrap();
    }
    fn idle(&mut self, _now: Instant) {
        self.idles += 1;
    }
    fn connection_timed_out(&mut self, _now: Instant) {
        self.timed_out += 1;
    }
    fn get_attribute(
        &mut self,
        _now: Instant,
        p: Path,
        out: &mut MessageBuf,
    ) -> Result<(), CipError> {
        if p == Path::new(0x64, 1, 1) {
            out.push(self.value).unwrap();
            Ok(())
        } else {
            Err(CipError::new(GeneralStatus::ObjectDoesNotExist))
        }
    }
    fn set_attribute(&mut self, _now: Instant, p: Path, data: &[u8]) -> Result<(), CipError> {
        match (p == Path::new(0x64, 1, 1), data) {
            (true, [v]) => {
                self.value = *v;
                Ok(())
            }
            (true, _) => Err(CipError::new(GeneralStatus::InvalidAttributeValue)),
            _ => Err(CipError::new(GeneralStatus::ObjectDoesNotExist)),
        }
    }
}

fn identity() -> Identity {
    let mut i = Identity {
        vendor_id: 272,
        device_type: 0,
        product_code: 1436,
        major_revision: 1,
        minor_revision: 2,
        status: 0,
        serial_number: 0x00C0FFEE,
        ..Identity::default()
    };
    i.product_name.push_str("1436 cPos").unwrap();
    i
}

fn slave_config(produced: u16, consumed: u16) -> SlaveConfig {
    SlaveConfig {
        mac: MacId::new(63).unwrap(),
        identity: identity(),
        produced_size: produced,
        consumed_size: consumed,
        baud_rate: 0,
        dup_mac_wait: Duration::from_millis(1000),
    }
}

struct Bus {
    now: Instant,
    master: Master,
    slave: Option<Slave<Echo>>,
    other: Option<Master>,
    log: Vec<(Instant, CanFrame)>,
    master_events: Vec<MasterEvent>,
    slave_events: Vec<SlaveEvent>,
    other_events: Vec<MasterEvent>,
}

impl Bus {
    fn new(produced: u16, consumed: u16) -> Self {
        let mut b = Bus {
            now: Instant::ZERO,
            master: Master::new(MasterConfig::new(MacId::new(63).unwrap())),
            slave: Some(Slave::new(
                slave_config(produced, consumed),
                Echo::default(),
            )),
            other: None,
            log: Vec::new(),
            master_events: Vec::new(),
            slave_events: Vec::new(),
            other_events: Vec::new(),
        };
        b.master.start(b.now);
        b.slave.as_mut().unwrap().start(b.now);
        b
    }

    fn step(&mut self) {
        self.now += Duration::from_millis(1);
        let now = self.now;
        if is_due(self.master.poll_timeout(), now) {
            self.master.handle_timeout(now);
        }
        if let Some(s) = &mut self.slave
            && is_due(s.poll_timeout(), now)
        {
            s.handle_timeout(now);
        }
        if let Some(o) = &mut self.other
            && is_due(o.poll_timeout(), now)
        {
            o.handle_timeout(now);
        }
        // Deliver until quiet: each station's frames go to every other station.
        loop {
            let mut frames = Vec::new();
            while let Some(f) = self.master.poll_transmit() {
                frames.push((0, f));
            }
            if let Some(s) = &mut self.slave {
                while let Some(f) = s.poll_transmit() {
                    frames.push((1, f));
                }
            }
            if let Some(o) = &mut self.other {
                while let Some(f) = o.poll_transmit() {
                    frames.push((2, f));
                }
            }
            if frames.is_empty() {
                break;
            }
            for (from, f) in frames {
                assert!(f.dlc() <= 8);
                self.log.push((now, f));
                if from != 0 {
                    self.master.handle_frame(now, &f);
                }
                if from != 1
                    && let Some(s) = &mut self.slave
                {
                    s.handle_frame(now, &f);
                }
                if from != 2
                    && let Some(o) = &mut self.other
                {
                    o.handle_frame(now, &f);
                }
            }
        }
        while let Some(e) = self.master.poll_event() {
            self.master_events.push(e);
        }
        if let Some(s) = &mut self.slave {
            while let Some(e) = s.poll_event() {
                self.slave_events.push(e);
            }
        }
        if let Some(o) = &mut self.other {
            while let Some(e) = o.poll_event() {
                self.other_events.push(e);
            }
        }
    }

    fn run(&mut self, ms: u64) {
        for _ in 0..ms {
            self.step();
        }
    }

    fn until(&mut self, limit_ms: u64, mut f: impl FnMut(&Bus) -> bool) {
        for _ in 0..limit_ms {
            if f(self) {
                return;
            }
            self.step();
        }
        panic!("condition not reached in {limit_ms} ms");
    }

    fn connected(&self) -> bool {
        self.master.state() == MasterState::Connected
    }
}

/// Identifier and data; the XID bit of explicit headers is cleared (it toggles per request).
fn raw(f: &CanFrame) -> (u16, Vec<u8>) {
    let id = f.id().as_standard().unwrap();
    let mut d = f.data().to_vec();
    if matches!(id, 0x5FB | 0x5FC | 0x5FE) && !d.is_empty() {
        d[0] &= !0x40;
    }
    (id, d)
}

#[test]
fn connect_sequence_on_the_wire() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    let frames: Vec<(u16, Vec<u8>)> = b.log.iter().map(|(_, f)| raw(f)).collect();
    // Duplicate MAC ID checks: master (MAC 0, 0x407) and slave (MAC 63, 0x5FF), twice each.
    assert_eq!(frames.iter().filter(|(id, _)| *id == 0x407).count(), 2);
    assert_eq!(frames.iter().filter(|(id, _)| *id == 0x5FF).count(), 2);
    assert!(frames.contains(&(0x5FF, vec![0x00, 0x10, 0x01, 0xEE, 0xFF, 0xC0, 0x00])));
    // Allocate explicit + polled on the Group 2 Only Unconnected port; body format 8/8.
    let alloc = frames.iter().position(|(id, _)| *id == 0x5FE).unwrap();
    assert_eq!(frames[alloc].1[1..], [0x4B, 0x03, 0x01, 0x03, 0x00]);
    assert_eq!(frames[alloc + 1].0, 0x5FB);
    assert_eq!(frames[alloc + 1].1[1..], [0xCB, 0x00]);
    // The explicit expected packet rate, 2500 ms = 0x09C4.
    assert_eq!(frames[alloc + 2].0, 0x5FC);
    assert_eq!(
        frames[alloc + 2].1[1..],
        [0x10, 0x05, 0x01, 0x09, 0xC4, 0x09]
    );
    // The product name comes fragmented: [0x80|MAC 0, first #0, 0x8E, 0x09, '1', '4', '3', '6'],
    // acknowledged by the master, then the last fragment.
    let name = frames
        .iter()
        .position(|(id, d)| *id == 0x5FB && d[0] & 0x80 != 0 && d[1] == 0x00)
        .unwrap();
    assert_eq!(
        frames[name].1,
        [0x80, 0x00, 0x8E, 0x09, b'1', b'4', b'3', b'6']
    );
    assert_eq!(frames[name + 1], (0x5FC, vec![0x80, 0xC0, 0x00]));
    assert_eq!(
        frames[name + 2],
        (0x5FB, vec![0x80, 0x81, b' ', b'c', b'P', b'o', b's'])
    );
    assert_eq!(frames[name + 3], (0x5FC, vec![0x80, 0xC1, 0x00]));
    // The poll rate 10 ms establishes the poll connection.
    assert!(
        frames
            .iter()
            .any(|(id, d)| *id == 0x5FC && d[1..] == [0x10, 0x05, 0x02, 0x09, 0x0A, 0x00])
    );
    let connected = b
        .master_events
        .iter()
        .find_map(|e| match e {
            MasterEvent::Connected {
                identity,
                produced_size,
                consumed_size,
            } => Some((identity.clone(), *produced_size, *consumed_size)),
            _ => None,
        })
        .unwrap();
    assert_eq!(connected, (identity(), 11, 13));
    assert_eq!(
        b.slave
            .as_ref()
            .unwrap()
            .connection_state(Connection::Polled),
        ConnectionState::Established
    );
}

#[test]
fn polled_io_with_fragmentation_both_ways() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    let cmd: Vec<u8> = (1..=13).collect();
    b.master.set_output(&cmd);
    b.master_events.clear();
    b.log.clear();
    b.run(50);
    let consumed = &b.slave.as_ref().unwrap().app().consumed;
    assert_eq!(consumed.last().unwrap(), &cmd);
    let mut expect: Vec<u8> = cmd[..11].to_vec();
    expect.reverse();
    // The response is the reversed command truncated to 11 bytes... reversed before truncation.
    let mut rev = cmd.clone();
    rev.reverse();
    let input = b
        .master_events
        .iter()
        .rev()
        .find_map(|e| match e {
            MasterEvent::Input(d) => Some(d.to_vec()),
            _ => None,
        })
        .unwrap();
    assert_eq!(input, rev[..11]);
    let frames: Vec<(u16, Vec<u8>)> = b.log.iter().map(|(_, f)| raw(f)).collect();
    assert!(frames.contains(&(0x5FD, vec![0x00, 1, 2, 3, 4, 5, 6, 7])));
    assert!(frames.contains(&(0x5FD, vec![0x81, 8, 9, 10, 11, 12, 13])));
    assert!(frames.contains(&(0x3FF, vec![0x00, 13, 12, 11, 10, 9, 8, 7])));
    assert!(frames.contains(&(0x3FF, vec![0x81, 6, 5, 4, 3])));
    // About one poll per 10 ms cycle.
    let polls = frames
        .iter()
        .filter(|(id, d)| *id == 0x5FD && d[0] == 0)
        .count();
    assert!((4..=6).contains(&polls), "{polls} polls in 50 ms");
    // Idle: zero-length polls.
    b.master.set_idle(true);
    b.run(30);
    assert!(b.slave.as_ref().unwrap().app().idles >= 2);
}

#[test]
fn short_images_are_not_fragmented() {
    let mut b = Bus::new(3, 5);
    b.until(3000, Bus::connected);
    b.master.set_output(&[1, 2, 3, 4, 5]);
    b.log.clear();
    b.run(20);
    let frames: Vec<(u16, Vec<u8>)> = b.log.iter().map(|(_, f)| raw(f)).collect();
    assert!(frames.contains(&(0x5FD, vec![1, 2, 3, 4, 5])));
    assert!(frames.contains(&(0x3FF, vec![5, 4, 3])));
    assert_eq!(b.master.sizes(), (3, 5));
}

#[test]
fn explicit_get_set_and_error_responses() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    let h = b
        .master
        .set_attribute(b.now, Path::new(0x64, 1, 1), &[42])
        .unwrap();
    let g = b
        .master
        .get_attribute(b.now, Path::new(0x64, 1, 1))
        .unwrap();
    let bad = b
        .master
        .set_attribute(b.now, Path::new(0x64, 1, 1), &[1, 2])
        .unwrap();
    let missing = b.master.get_attribute(b.now, Path::new(1, 1, 99)).unwrap();
    let ro = b
        .master
        .set_attribute(b.now, Path::new(1, 1, 1), &[0, 0])
        .unwrap();
    b.run(50);
    let done = |h| {
        b.master_events
            .iter()
            .find_map(|e| match e {
                MasterEvent::ExplicitDone { handle, result } if *handle == h => {
                    Some(result.clone())
                }
                _ => None,
            })
            .unwrap()
    };
    assert_eq!(done(h).unwrap().len(), 0);
    assert_eq!(&done(g).unwrap()[..], &[42]);
    assert_eq!(
        done(bad),
        Err(ExplicitFailure::Refused(CipError::new(
            GeneralStatus::InvalidAttributeValue
        )))
    );
    assert_eq!(
        done(missing),
        Err(ExplicitFailure::Refused(CipError::new(
            GeneralStatus::AttributeNotSupported
        )))
    );
    assert_eq!(
        done(ro),
        Err(ExplicitFailure::Refused(CipError::new(
            GeneralStatus::AttributeNotSettable
        )))
    );
}

#[test]
fn explicit_keep_alive_holds_the_connection() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    b.run(30_000);
    assert!(b.connected());
    assert!(!b.master_events.contains(&MasterEvent::ConnectionLost));
    assert_eq!(
        b.slave
            .as_ref()
            .unwrap()
            .connection_state(Connection::Explicit),
        ConnectionState::Established
    );
}

#[test]
fn slave_gone_master_loses_and_reconnects() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    let slave = b.slave.take();
    b.until(100, |b| {
        b.master_events.contains(&MasterEvent::ConnectionLost)
    });
    assert_eq!(b.master.state(), MasterState::Disconnected);
    // Reconnect attempts time out while it is away.
    b.run(3000);
    assert!(
        b.master_events
            .iter()
            .any(|e| matches!(e, MasterEvent::ConnectFailed(ConnectError::Timeout { .. })))
    );
    // The slave is back; it still holds the allocation for this master (its poll connection
    // timed out): the master's Allocate is answered "already in requested mode/state", the
    // master releases the set and allocates again.
    b.slave = slave;
    b.until(3000, Bus::connected);
}

#[test]
fn restarted_master_releases_and_allocates_again() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    // The master process restarts (same MAC ID) without releasing.
    b.master = Master::new(MasterConfig::new(MacId::new(63).unwrap()));
    b.master.start(b.now);
    b.log.clear();
    b.until(2500, Bus::connected);
    let frames: Vec<(u16, Vec<u8>)> = b.log.iter().map(|(_, f)| raw(f)).collect();
    let unconnected: Vec<&Vec<u8>> = frames
        .iter()
        .filter(|(id, _)| *id == 0x5FE || *id == 0x5FB)
        .map(|(_, d)| d)
        .take(6)
        .collect();
    assert_eq!(unconnected[0][1..], [0x4B, 0x03, 0x01, 0x03, 0x00]);
    assert_eq!(unconnected[1][1..], [0x94, 0x0B, 0xFF]);
    assert_eq!(unconnected[2][1..], [0x4C, 0x03, 0x01, 0x03]);
    assert_eq!(unconnected[3][1..], [0xCC]);
    assert_eq!(unconnected[4][1..], [0x4B, 0x03, 0x01, 0x03, 0x00]);
    assert_eq!(unconnected[5][1..], [0xCB, 0x00]);
}

#[test]
fn master_gone_slave_times_out_and_frees_the_allocation() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    b.master.disconnect(b.now);
    b.run(5);
    // Released explicitly: both connections are gone at once.
    let s = b.slave.as_ref().unwrap();
    assert_eq!(
        s.connection_state(Connection::Polled),
        ConnectionState::NonExistent
    );
    assert_eq!(s.master(), None);
    b.master.connect(b.now);
    b.until(1000, Bus::connected);
    // Now silence the master: the poll connection times out after 4 x 10 ms.
    let master = std::mem::replace(
        &mut b.master,
        Master::new(MasterConfig::new(MacId::new(63).unwrap())),
    );
    b.run(50);
    let s = b.slave.as_ref().unwrap();
    assert_eq!(
        s.connection_state(Connection::Polled),
        ConnectionState::TimedOut
    );
    assert_eq!(s.app().timed_out, 1);
    drop(master);
    // The explicit connection (2500 ms rate) times out after 10 s: the allocation ends.
    b.run(10_100);
    assert_eq!(b.slave.as_ref().unwrap().master(), None);
}

#[test]
fn second_master_is_refused_with_object_state_conflict() {
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    let mut cfg = MasterConfig::new(MacId::new(63).unwrap());
    cfg.mac = MacId::new(1).unwrap();
    let mut other = Master::new(cfg);
    other.start(b.now);
    b.other = Some(other);
    b.run(2100);
    assert!(b.other_events.iter().any(|e| matches!(
        e,
        MasterEvent::ConnectFailed(ConnectError::Refused {
            error: CipError {
                general: GeneralStatus::ObjectStateConflict,
                additional: 1
            },
            ..
        })
    )));
    assert!(b.connected());
}

#[test]
fn duplicate_mac_of_the_master() {
    // A second master with the same MAC 0 comes up later: it sees the first one's response to
    // its check and goes faulted; the first stays connected.
    let mut b = Bus::new(11, 13);
    b.until(3000, Bus::connected);
    let mut other = Master::new(MasterConfig::new(MacId::new(63).unwrap()));
    other.start(b.now);
    b.other = Some(other);
    b.run(2500);
    assert_eq!(b.other.as_ref().unwrap().state(), MasterState::Faulted);
    assert!(matches!(
        b.other_events.first(),
        Some(MasterEvent::DuplicateMac(c)) if c.response
    ));
    assert!(b.connected());
    // The first master answered on 0x407 with the response bit.
    assert!(
        b.log
            .iter()
            .any(|(_, f)| raw(f).0 == 0x407 && f.data()[0] & 0x80 != 0)
    );
}

#[test]
fn duplicate_mac_of_the_slave() {
    // Two slaves with MAC 63 starting at once: each sees the other's request and faults.
    let mut b = Bus::new(11, 13);
    let mut twin = Slave::new(slave_config(11, 13), Echo::default());
    twin.start(b.now);
    let f = twin.poll_transmit().unwrap();
    b.slave.as_mut().unwrap().handle_frame(b.now, &f);
    assert_eq!(
        b.slave.as_ref().unwrap().network_state(),
        NetworkState::Faulted
    );
    b.run(3000);
    assert!(!b.connected());
    assert!(
        b.master_events
            .iter()
            .any(|e| matches!(e, MasterEvent::ConnectFailed(_)))
    );
}

#[test]
fn unconnected_port_refuses_other_services() {
    let mut s = Slave::new(slave_config(11, 13), Echo::default());
    s.start(Instant::ZERO);
    while s.poll_transmit().is_some() {}
    s.handle_timeout(Instant::from_millis(1000));
    s.handle_timeout(Instant::from_millis(2000));
    while s.poll_transmit().is_some() {}
    let id = CanId::standard(0x5FE).unwrap();
    s.handle_frame(
        Instant::from_millis(2001),
        &CanFrame::new(id, &[0x00, 0x0E, 1, 1, 1]).unwrap(),
    );
    let r = s.poll_transmit().unwrap();
    assert_eq!(raw(&r), (0x5FB, vec![0x00, 0x94, 0x08, 0xFF]));
    // Bit-strobe is not offered.
    s.handle_frame(
        Instant::from_millis(2002),
        &CanFrame::new(id, &[0x00, 0x4B, 3, 1, 0x04, 0]).unwrap(),
    );
    assert_eq!(
        raw(&s.poll_transmit().unwrap()),
        (0x5FB, vec![0x00, 0x94, 0x02, 0x02])
    );
    // Explicit requests before allocation get no answer.
    let req = CanId::standard(0x5FC).unwrap();
    s.handle_frame(
        Instant::from_millis(2003),
        &CanFrame::new(req, &[0x00, 0x0E, 1, 1, 1]).unwrap(),
    );
    assert_eq!(s.poll_transmit(), None);
}

#[test]
fn other_body_formats_are_refused() {
    // A hand-made slave answers the Allocate with body format 2 (16/16).
    let mut m = Master::new(MasterConfig::new(MacId::new(63).unwrap()));
    m.start(Instant::ZERO);
    m.handle_timeout(Instant::from_millis(1000));
    m.handle_timeout(Instant::from_millis(2000));
    while m.poll_transmit().is_some() {}
    let id = CanId::standard(0x5FB).unwrap();
    m.handle_frame(
        Instant::from_millis(2001),
        &CanFrame::new(id, &[0x40, 0xCB, 0x02]).unwrap(),
    );
    let mut events = Vec::new();
    while let Some(e) = m.poll_event() {
        events.push(e);
    }
    assert!(
        events.contains(&MasterEvent::ConnectFailed(
            ConnectError::UnsupportedBodyFormat(2)
        )),
        "{events:?}"
    );
    assert_eq!(m.state(), MasterState::Disconnected);
}
