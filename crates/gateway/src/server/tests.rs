//! The fair queue and the line reader against their contracts.

use std::io::BufReader;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Condvar, Mutex};

use crate::command::Command;

use super::client::{Client, OutboxState, leading_seq, read_line};
use super::queues::{FairQueue, Job, Work};

fn client(id: u64) -> Arc<Client> {
    Arc::new(Client {
        id,
        out: Mutex::new(OutboxState::default()),
        cond: Condvar::new(),
        events: AtomicBool::new(false),
    })
}

fn job(c: &Arc<Client>, seq: u32) -> Job {
    Job {
        client: c.clone(),
        seq: Some(seq),
        work: Work::Lss(Command::LssStore),
        audit: None,
    }
}

#[test]
fn the_queue_serves_connections_round_robin() {
    let (a, b, c) = (client(1), client(2), client(3));
    let mut q = FairQueue::default();
    for seq in 0..5 {
        q.push(job(&a, seq));
    }
    q.push(job(&b, 100));
    q.push(job(&b, 101));
    q.push(job(&c, 200));
    let order: Vec<_> = std::iter::from_fn(|| q.pop())
        .map(|j| (j.client.id, j.seq.unwrap()))
        .collect();
    assert_eq!(
        order,
        [
            (1, 0),
            (2, 100),
            (3, 200),
            (1, 1),
            (2, 101),
            (1, 2),
            (1, 3),
            (1, 4)
        ]
    );
}

#[test]
fn lines_are_cut_at_the_limit_and_the_rest_skipped() {
    let mut r = BufReader::with_capacity(8, &b"[1] abcdefghijkl\n[2] ok\nlast"[..]);
    let mut line = Vec::new();
    assert_eq!(read_line(&mut r, &mut line, 10).unwrap(), (true, false));
    assert_eq!(line, b"[1] abcdef");
    assert_eq!(leading_seq(&line), Some(1));
    line.clear();
    assert_eq!(read_line(&mut r, &mut line, 10).unwrap(), (false, false));
    assert_eq!(line, b"[2] ok\n");
    line.clear();
    assert_eq!(read_line(&mut r, &mut line, 10).unwrap(), (false, true));
    assert_eq!(line, b"last");
}
