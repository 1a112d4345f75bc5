//! The gateway server: connections (TCP, Unix socket, stdio, any byte stream) in front of one
//! [`Network`](canola::Network).
//!
//! Threads and queues:
//! * Each connection has a reader (lines in, parse, answer or dispatch) and a writer (its
//!   outbox to the stream). Settings (`set node`, `set sdo_timeout`, ...) belong to the
//!   connection and apply to the requests read after them.
//! * SDO requests go to one queue per node: requests to one node run one after another
//!   (CANopen has one SDO channel per node), requests to different nodes run in parallel on
//!   the bus. NMT commands to a node go to its queue too, so that `write` then `start` happen
//!   in that order; NMT to all nodes (node 0) and the settings are answered at once. Each
//!   queue serves its connections round-robin, so a connection with many requests waiting
//!   delays another's by at most one request per node. One dispatcher thread serves every
//!   node's queue: it starts each node's next request as a pending SDO request, drives the
//!   network while any runs and answers each as it ends; no thread is made per node.
//! * LSS requests share one queue (one LSS channel per bus), served by a thread of its own,
//!   started with the first LSS request: LSS services are sequences of steps that block.
//! * Replies carry the request's sequence number; replies to different nodes may overtake one
//!   another.
//! * Bounds per connection: a line longer than [`Config::max_line`] is refused with
//!   `ERROR:600` (its beginning still gives the sequence number), at most
//!   [`Config::max_in_flight`] requests are waiting or unsent (the reader stops reading until
//!   the writer catches up), at most [`Config::max_events`] event lines wait in the outbox
//!   (later ones are dropped for that connection only), and an upload is at most
//!   [`Config::max_upload`] bytes. A connection whose peer stopped reading or vanished holds
//!   only its own requests: the dispatcher never waits for a connection.
//! * Access control, the audit log and the limits against hostile clients live in
//!   [`crate::access`], [`crate::audit_log`] and [`crate::conn_limits`]; this file calls them
//!   at a few marked hooks (the accept loops, the start of a line, the queue's reply).
//! * While no request runs, the dispatcher drives the network (heartbeats, boot-up and EMCY
//!   are received; see [`Config::drive_period`]); a thread turns its events into event lines
//!   for the connections that asked for them with `_events 1`.
//!
//! Files by layer: `config` ([`Config`], [`Version`]), `client` (a connection's outbox and
//! line reading), `queues` (the queues, the shared state, the event thread), `dispatch` (the
//! dispatcher and the LSS thread), `gateway` ([`Gateway`]: connections and dispatch).

mod client;
mod config;
mod dispatch;
mod gateway;
mod queues;
#[cfg(test)]
mod tests;

pub use config::{Config, Version};
pub use gateway::Gateway;
