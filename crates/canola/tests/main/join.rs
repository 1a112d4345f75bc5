//! `join_all`: several operations run together on one thread. Waited on, its loop drives the
//! network between polls of the operations, so transfers to different nodes overlap on the bus
//! (compared here in bus time, on the virtual clock); awaited, it polls them on tokio. Results
//! come in order, an absent node's timeout holds nobody else up, nested operations work, and
//! dropping the join cancels what runs.

use std::collections::VecDeque;

use canola::{
    BusConfig, CanFrame, Duration, Error, Instant, MemoryBus, Network, NodeId, Operation,
    SimDevice, Station, join_all,
};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

/// How long a device takes to answer.
const LAG: Duration = Duration::from_millis(2);

/// A simulated device that answers [`LAG`] late, as a slow device does: the bus time of an
/// SDO transfer is then mostly the device's, and transfers to two devices can overlap.
struct Slow {
    device: SimDevice,
    /// Answers held back, with when they go.
    held: VecDeque<(Instant, CanFrame)>,
    now: Instant,
}

impl Slow {
    fn hold(&mut self, now: Instant) {
        self.now = now;
        while let Some(f) = self.device.poll_transmit() {
            self.held.push_back((now + LAG, f));
        }
    }
}

impl Station for Slow {
    fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.device.handle_frame(now, frame);
        self.hold(now);
    }
    fn handle_timeout(&mut self, now: Instant) {
        self.device.handle_timeout(now);
        self.hold(now);
    }
    fn poll_transmit(&mut self) -> Option<CanFrame> {
        match self.held.front() {
            Some((at, _)) if *at <= self.now => self.held.pop_front().map(|(_, f)| f),
            _ => None,
        }
    }
    fn poll_timeout(&self) -> Option<Instant> {
        let held = self.held.front().map(|(at, _)| *at);
        match (held, self.device.poll_timeout()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }
}

/// A fresh 1 Mbit/s bus with slow simulated devices at nodes 5 and 6 (node 9 is absent).
fn rig() -> (MemoryBus, Network) {
    let bus = MemoryBus::with_config(BusConfig {
        bitrate: Some(1_000_000),
        ..BusConfig::default()
    });
    let net = Network::new(bus.endpoint());
    for id in [5, 6] {
        bus.attach(Slow {
            device: SimDevice::from_eds(n(id), EDS).unwrap(),
            held: VecDeque::new(),
            now: bus.now(),
        });
    }
    (bus, net)
}

/// A segmented read of the device name (several frames each way), with the bus time it ended at.
fn name_read(net: &Network, id: u8) -> Operation<'static, (Vec<u8>, Instant)> {
    let read = net
        .node(n(id))
        .sdo()
        .timeout(Duration::from_millis(100))
        .read((0x1008, 0));
    let net = net.clone();
    Operation::new(async move {
        let v = read.await?;
        Ok::<_, Error>((v, net.now()))
    })
}

#[test]
fn two_nodes_read_together_in_about_the_bus_time_of_one() {
    let (_bus, net) = rig();
    let t0 = net.now();
    let (name, _) = name_read(&net, 5).wait().unwrap();
    let one = net.now() - t0;
    assert!(name.len() > 4, "a segmented transfer");

    let (_bus, net) = rig();
    let t0 = net.now();
    name_read(&net, 5).wait().unwrap();
    name_read(&net, 6).wait().unwrap();
    let in_turn = net.now() - t0;

    let (_bus, net) = rig();
    let t0 = net.now();
    let r = join_all([name_read(&net, 5), name_read(&net, 6)])
        .wait()
        .unwrap();
    let joined = net.now() - t0;
    let values: Vec<Vec<u8>> = r.into_iter().map(|r| r.unwrap().0).collect();
    assert_eq!(values, [name.clone(), name]);
    assert!(
        in_turn.as_micros() + 10 >= one.as_micros() * 2,
        "one after another: {} us for one of {} us",
        in_turn.as_micros(),
        one.as_micros()
    );
    assert!(
        joined.as_micros() * 4 < one.as_micros() * 5,
        "joined: {} us, one alone: {} us",
        joined.as_micros(),
        one.as_micros()
    );
}

#[test]
fn an_absent_node_does_not_hold_up_the_others() {
    let (_bus, net) = rig();
    let t0 = net.now();
    let r = join_all([name_read(&net, 9), name_read(&net, 5), name_read(&net, 6)])
        .wait()
        .unwrap();
    let all = net.now() - t0;
    assert_eq!(r.len(), 3);
    match &r[0] {
        Err(Error::Sdo(e)) => assert_eq!(e.node, n(9)),
        other => panic!("node 9 answered: {other:?}"),
    }
    for r in &r[1..] {
        let (_, at) = r.as_ref().unwrap();
        assert!(
            *at - t0 < Duration::from_millis(20),
            "a present node waited for the absent one: {}",
            *at - t0
        );
    }
    assert!(
        all >= Duration::from_millis(100),
        "the timeout ran out: {all}"
    );
}

#[test]
fn results_come_in_the_order_of_the_operations() {
    let (_bus, net) = rig();
    // The slow one first: node 5 makes two transfers, node 6 one.
    let slow = {
        let node = net.node(n(5));
        Operation::new(async move {
            node.sdo().write((0x1017, 0), 700u16).await?;
            let ms: u16 = node.read_typed((0x1017, 0)).await?;
            Ok::<_, Error>(u32::from(ms))
        })
    };
    let fast = {
        let node = net.node(n(6));
        Operation::new(async move { node.read_typed::<u32>((0x1018, 1)).await })
    };
    let bad = Operation::ready(Err(Error::InvalidRequest(
        canola::error::Misuse::StateOfAll,
    )));
    let r = join_all([slow, fast, bad]).wait().unwrap();
    assert_eq!(r[0].as_ref().unwrap(), &700);
    let vendor = net
        .node(n(6))
        .read_typed::<u32>((0x1018, 1))
        .wait()
        .unwrap();
    assert_eq!(r[1].as_ref().unwrap(), &vendor);
    assert!(matches!(r[2], Err(Error::InvalidRequest(_))));
    assert!(
        join_all(Vec::<Operation<'static, ()>>::new())
            .wait()
            .unwrap()
            .is_empty()
    );
}

#[test]
fn nested_operations_and_joins_run_inside_a_join() {
    let (_bus, net) = rig();
    // Each body awaits several facade operations, one of them a join of its own, and a wait
    // with a deadline on the bus.
    let body = |id: u8| {
        let net = net.clone();
        Operation::new(async move {
            let node = net.node(n(id));
            node.sdo()
                .write((0x1017, 0), 100u16 * u16::from(id))
                .await?;
            // Absent nodes 15 and 16 (two reads of one node would run one after the other).
            let inner = join_all([name_read(&net, id), name_read(&net, id + 10)]).await?;
            net.run_for(Duration::from_millis(5)).await?;
            let ms: u16 = node.read_typed((0x1017, 0)).await?;
            let name_ok = inner[0].is_ok();
            let absent_failed = inner[1].is_err();
            Ok::<_, Error>((ms, name_ok, absent_failed))
        })
    };
    let t0 = net.now();
    let r = join_all([body(5), body(6)]).wait().unwrap();
    let took = net.now() - t0;
    assert_eq!(r[0].as_ref().unwrap(), &(500, true, true));
    assert_eq!(r[1].as_ref().unwrap(), &(600, true, true));
    // Both absent-node timeouts ran at the same time.
    assert!(took < Duration::from_millis(190), "took {took}");
}

#[test]
fn a_blocking_wait_inside_a_joined_body_works() {
    let (_bus, net) = rig();
    let other = name_read(&net, 6);
    let node = net.node(n(5));
    let blocking = Operation::new(async move {
        // Waited on inside the join's body: it drives the network itself.
        let v: u32 = node.read_typed((0x1018, 1)).wait()?;
        Ok::<_, Error>(v)
    });
    let other = Operation::new(async move { other.await.map(|(v, _)| v.len() as u32) });
    let r = join_all([blocking, other]).wait().unwrap();
    assert!(r.iter().all(Result::is_ok), "{r:?}");
}

#[cfg(feature = "tokio")]
mod awaited {
    use super::*;
    use canola::{Received, Transport};
    use std::future::IntoFuture;

    /// What a join of reads of nodes 5, 6 and 9 gives: values, or the errors' text.
    fn three_reads(net: &Network) -> Operation<'static, Vec<Result<Vec<u8>, Error>>> {
        let reads = [5, 6, 9].map(|id| {
            let r = name_read(net, id);
            Operation::new(async move { r.await.map(|(v, _)| v) })
        });
        join_all(reads)
    }

    fn said(r: Vec<Result<Vec<u8>, Error>>) -> Vec<Result<Vec<u8>, String>> {
        r.into_iter()
            .map(|r| r.map_err(|e| e.to_string()))
            .collect()
    }

    #[test]
    fn waited_and_awaited_joins_agree() {
        let (_bus, net) = rig();
        let waited = said(three_reads(&net).wait().unwrap());
        let (_bus, net) = rig();
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .start_paused(true)
            .build()
            .unwrap();
        let awaited = said(rt.block_on(three_reads(&net).into_future()).unwrap());
        assert_eq!(waited, awaited);
        assert!(waited[0].is_ok() && waited[1].is_ok() && waited[2].is_err());
    }

    #[tokio::test(start_paused = true)]
    async fn dropping_an_awaited_join_aborts_its_transfers() {
        let bus = MemoryBus::new();
        let net = Network::new(bus.endpoint());
        let mut tap = bus.endpoint();
        // Nobody answers: each read would run into its 10 s timeout.
        let reads = [5, 6].map(|id| {
            net.node(n(id))
                .sdo()
                .timeout(Duration::from_secs(10))
                .read((0x1018, 1))
        });
        let r = tokio::time::timeout(
            std::time::Duration::from_millis(50),
            join_all(reads).into_future(),
        )
        .await;
        assert!(r.is_err(), "the tokio timeout fires first");
        let mut aborted = Vec::new();
        while let Ok(Some(got)) = tap.try_recv() {
            if let Received::Frame { frame, .. } = got
                && frame.data()[0] == 0x80
                && frame.data()[4..8] == 0x0800_0000u32.to_le_bytes()
            {
                aborted.push(frame.cob_id());
            }
        }
        assert_eq!(aborted, [Some(0x605), Some(0x606)]);
        assert_eq!(net.occupancy().requests, 0);
    }
}

#[test]
fn a_sign_of_life_ends_its_wait_and_an_absent_node_times_out_meanwhile() {
    let (_bus, net) = rig();
    // The device's heartbeat (0x1017: 500 ms) is the sign of life; node 9 gives none.
    let since = net.now();
    let deadline = since + Duration::from_secs(1);
    let wait = |id: u8| {
        let net2 = net.clone();
        let w = net.node(n(id)).nmt().wait_for_life(Some(since), deadline);
        Operation::new(async move { Ok::<_, Error>((w.await?, net2.now())) })
    };
    let r = join_all([wait(5), wait(9)]).wait().unwrap();
    let (alive, at) = *r[0].as_ref().unwrap();
    assert!(alive);
    assert!(at - since <= Duration::from_millis(501), "{}", at - since);
    assert_eq!(*r[1].as_ref().unwrap(), (false, deadline));
}

#[test]
fn wait_all_with_hands_out_progress_between_steps_in_order() {
    use std::sync::mpsc;
    let (_bus, net) = rig();
    let (tx, rx) = mpsc::channel();
    let ops = [5u8, 6].map(|id| {
        let tx = tx.clone();
        let node = net.node(n(id));
        Operation::new(async move {
            let _ = tx.send((id, "start"));
            let v: u32 = node.read_typed((0x1018, 1)).await?;
            let _ = tx.send((id, "read"));
            node.sdo().write((0x1017, 0), 250u16).await?;
            let _ = tx.send((id, "written"));
            Ok::<_, Error>(v)
        })
    });
    // Not Send: the callback side of the channel stays on this thread.
    let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let mut calls = 0;
    let r = canola::wait_all_with(ops, || {
        calls += 1;
        seen.borrow_mut().extend(rx.try_iter());
    });
    seen.borrow_mut().extend(rx.try_iter());
    assert!(r.iter().all(Result::is_ok), "{r:?}");
    assert!(calls > 0);
    let seen = seen.borrow();
    for id in [5, 6] {
        let mine: Vec<_> = seen
            .iter()
            .filter(|(i, _)| *i == id)
            .map(|(_, s)| *s)
            .collect();
        assert_eq!(mine, ["start", "read", "written"]);
    }
    // The two bodies ran together: both started before either finished its read.
    assert_eq!(seen[..2], [(5, "start"), (6, "start")]);
}
