//! Every operation waits by one path: a single SDO request and the same request inside an
//! operation of the application's own code, each finished by blocking and by awaiting, give
//! the same result for the same transfer.

use std::future::IntoFuture;

use canola::{Duration, Error, MemoryBus, Method, Network, NodeId, Operation, SimDevice};

const EDS: &[u8] = include_bytes!("../../../../eds/burkert-generic.eds");

fn n(id: u8) -> NodeId {
    NodeId::new(id).unwrap()
}

/// A fresh bus with the simulated device at node 5.
fn rig() -> (MemoryBus, Network) {
    let bus = MemoryBus::new();
    let net = Network::new(bus.endpoint());
    bus.attach(SimDevice::from_eds(n(5), EDS).unwrap());
    (bus, net)
}

/// One transfer: on node `node`, read (`None`) or write (`Some`) `entry` with `method`.
type Case = (u8, (u16, u8), Option<Vec<u8>>, Method);

fn cases() -> Vec<Case> {
    let long = b"a name longer than four bytes".to_vec();
    vec![
        (5, (0x1018, 1), None, Method::Normal),
        (5, (0x1008, 0), None, Method::Normal),
        (5, (0x1008, 0), None, Method::Block),
        (5, (0x1017, 0), Some(vec![0xE8, 0x03]), Method::Normal),
        (5, (0x2002, 3), Some(long.clone()), Method::Normal),
        (5, (0x2002, 3), Some(long), Method::Block),
        (5, (0x6543, 0), None, Method::Normal), // no such object: abort
        (5, (0x1000, 0), Some(vec![1, 2, 3, 4]), Method::Normal), // read-only: abort
        (9, (0x1000, 0), None, Method::Normal), // nobody there: timeout
    ]
}

/// The operation for `case`, as the request form or wrapped as code.
fn operation(net: &Network, case: &Case, as_code: bool) -> Operation<'static, Vec<u8>> {
    let (node, entry, value, method) = case.clone();
    let sdo = net
        .node(n(node))
        .sdo()
        .method(method)
        .timeout(Duration::from_millis(100));
    let op = match value {
        None => sdo.read(entry),
        Some(v) => {
            let write = sdo.write(entry, v);
            Operation::new(async move { write.await.map(|()| Vec::new()) })
        }
    };
    if as_code {
        Operation::new(async move { op.await })
    } else {
        op
    }
}

/// What a result says, with the error as its text (which names node, object and abort code).
fn said(r: Result<Vec<u8>, Error>) -> Result<Vec<u8>, String> {
    r.map_err(|e| e.to_string())
}

#[test]
fn request_and_code_forms_agree_when_waited_on_and_awaited() {
    for case in cases() {
        let mut seen = Vec::new();
        for as_code in [false, true] {
            let (_bus, net) = rig();
            seen.push(said(operation(&net, &case, as_code).wait()));
            let (_bus, net) = rig();
            let rt = tokio::runtime::Builder::new_current_thread()
                .enable_time()
                .start_paused(true)
                .build()
                .unwrap();
            seen.push(said(
                rt.block_on(operation(&net, &case, as_code).into_future()),
            ));
        }
        assert!(
            seen.windows(2).all(|w| w[0] == w[1]),
            "{case:?}: the four ways differ: {seen:#?}"
        );
    }
}
