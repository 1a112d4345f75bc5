//! A node's NMT state through `node.nmt()`: state, waiting for boot-up and for a state, on the
//! virtual-clock bus against the simulator and against raw frames.

use canola::error::Awaited;
use canola::mem::MemoryBus;
use canola::transport::Transport;
use canola::{Error, Network, NmtState, SimDevice};
use canola_frame::{CanFrame, CanId, Duration, NodeId};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

#[test]
fn reset_then_wait_for_bootup_and_states_of_the_simulator() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let nmt = net.node(n(5)).nmt();
    assert_eq!(nmt.state(), None);
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    nmt.wait_for_bootup(Duration::from_secs(1)).wait().unwrap();
    // The device's heartbeat (0x1017 = 500 ms in this EDS) follows.
    nmt.wait_for_state(NmtState::PreOperational, Duration::from_secs(1))
        .wait()
        .unwrap();
    nmt.start().unwrap();
    nmt.wait_for_state(NmtState::Operational, Duration::from_secs(1))
        .wait()
        .unwrap();
    assert_eq!(nmt.state(), Some(NmtState::Operational));

    nmt.reset_node().unwrap();
    // Let the boot-up and the next heartbeat both arrive before anyone waits.
    net.run_for(Duration::from_secs(2)).wait().unwrap();
    assert_eq!(nmt.state(), Some(NmtState::PreOperational));
    nmt.wait_for_bootup(Duration::from_millis(10))
        .wait()
        .unwrap();
    // That boot-up is consumed: a second wait times out (on the virtual clock).
    let t0 = net.now();
    let e = nmt
        .wait_for_bootup(Duration::from_millis(300))
        .wait()
        .unwrap_err();
    // What was awaited and for how long are values, and the message says them.
    match &e {
        Error::Timeout {
            awaited: Awaited::BootUp { node },
            after,
        } => {
            assert_eq!(*node, n(5));
            assert_eq!(*after, Duration::from_millis(300));
        }
        other => panic!("expected a boot-up timeout, got {other}"),
    }
    assert_eq!(
        e.to_string(),
        format!(
            "timed out after {} waiting for a boot-up from node {}",
            Duration::from_millis(300),
            n(5)
        )
    );
    assert_eq!(format!("{e:?}"), e.to_string());
    assert!(net.now() >= t0 + Duration::from_millis(300));
    let e = nmt
        .wait_for_state(NmtState::Stopped, Duration::from_millis(100))
        .wait()
        .unwrap_err();
    assert!(
        matches!(
            e,
            Error::Timeout {
                awaited: Awaited::State {
                    state: NmtState::Stopped,
                    ..
                },
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("to report Stopped"), "{e}");
}

/// python-canopen's race: a boot-up and a heartbeat handled together leave the state at
/// Pre-operational, and a waiter checking the state for "boot-up" misses it.
#[test]
fn a_bootup_followed_at_once_by_a_heartbeat_is_not_missed() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    let mut other = bus.endpoint();
    let nmt = net.node(n(9)).nmt();
    let id = CanId::standard(0x709).unwrap();
    other.send(&CanFrame::new(id, &[0x00]).unwrap()).unwrap();
    other.send(&CanFrame::new(id, &[0x7F]).unwrap()).unwrap();
    net.run_for(Duration::from_millis(1)).wait().unwrap();
    assert_eq!(nmt.state(), Some(NmtState::PreOperational));
    nmt.wait_for_bootup(Duration::from_millis(50))
        .wait()
        .unwrap();
    // A handle made after the boot-up waits for the next one.
    let later = net.node(n(9)).nmt();
    assert!(
        later
            .wait_for_bootup(Duration::from_millis(50))
            .wait()
            .is_err()
    );
    other.send(&CanFrame::new(id, &[0x00]).unwrap()).unwrap();
    later
        .wait_for_bootup(Duration::from_millis(50))
        .wait()
        .unwrap();
    assert_eq!(later.state(), Some(NmtState::BootUp));
    assert!(matches!(
        canola::Nmt::all(&net)
            .wait_for_bootup(Duration::from_millis(1))
            .wait(),
        Err(Error::InvalidRequest(_))
    ));
}

/// Boot-ups count per node from `add_node`: a node's boot-up that arrived while the master
/// waited for another node is there for a handle made afterwards.
#[test]
fn a_bootup_that_arrived_before_the_handle_was_made_is_not_lost() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    net.add_node(n(5));
    net.add_node(n(6));
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    bus.attach(SimDevice::from_eds(n(6), EDS).unwrap());
    net.node(n(5))
        .nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()
        .unwrap();
    // Node 6 booted while node 5 was waited for.
    net.node(n(6))
        .nmt()
        .wait_for_bootup(Duration::from_millis(100))
        .wait()
        .unwrap();
    // Consumed: the next wait, on any handle, waits for the next boot-up.
    assert!(
        net.node(n(6))
            .nmt()
            .wait_for_bootup(Duration::from_millis(100))
            .wait()
            .is_err()
    );

    // The same after a reset of all nodes.
    canola::Nmt::all(&net).reset_node().unwrap();
    net.node(n(5))
        .nmt()
        .wait_for_bootup(Duration::from_secs(1))
        .wait()
        .unwrap();
    net.node(n(6))
        .nmt()
        .wait_for_bootup(Duration::from_millis(100))
        .wait()
        .unwrap();
}

/// A boot-up heard before `add_node` does not count for the node's waits.
#[test]
fn a_bootup_before_add_node_does_not_count() {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(n(7), EDS).unwrap());
    net.run_for(Duration::from_millis(10)).wait().unwrap();
    assert_eq!(net.last_state(n(7)), Some(NmtState::BootUp));
    let node = net.add_node(n(7));
    assert!(
        node.nmt()
            .wait_for_bootup(Duration::from_millis(50))
            .wait()
            .is_err()
    );
}
