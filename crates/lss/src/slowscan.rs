//! Identify-range scan ("slowscan"): finding slaves of a known vendor and product by binary
//! search over serial numbers (and revision numbers) with identify remote slave
//! (CiA 305, requests 0x46..=0x4B, answer 0x4F).
//!
//! Each probe sends the six identify requests for a revision range and a serial range; every
//! slave inside both ranges answers. An answered probe whose serial range holds more than one
//! value is split in halves, lower half first; once the serial is pinned the revision range is
//! split the same way; a probe with one revision and one serial is a found slave. Silent probes
//! are dropped. The search is a depth-first walk with an explicit stack of at most 65 probes,
//! so it needs no allocator, and finds configured and unconfigured slaves alike (identify
//! remote slave does not depend on the LSS state or the node-ID).
//!
//! Cost: about 2 × 32 probes per slave plus shared prefixes; each probe costs one response
//! timeout when silent, or always under [`ResponsePolicy::WholeWindow`].

use canola_frame::{Duration, Instant};
use heapless::Vec;

use crate::address::LssAddress;
use crate::error::LssError;
use crate::fastscan::{AddressList, MAX_SLAVES};
use crate::machine::{Driven, Io, MasterEvent, Reply, ResponsePolicy, driven_machine};
use crate::service::{IdentifyQuery, Range};
use crate::wire::cs;

/// What to search and how fast.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlowscanConfig {
    /// Vendor-ID (exact).
    pub vendor_id: u32,
    /// Product code (exact).
    pub product_code: u32,
    /// Revision numbers to search.
    pub revision: Range,
    /// Serial numbers to search.
    pub serial: Range,
    /// Wait per probe.
    pub response_timeout: Duration,
    /// When to move on after an answer.
    pub policy: ResponsePolicy,
}

impl SlowscanConfig {
    /// Every revision and serial of one product, 25 ms per probe, whole windows.
    pub const fn product(vendor_id: u32, product_code: u32) -> Self {
        Self {
            vendor_id,
            product_code,
            revision: Range::ALL,
            serial: Range::ALL,
            response_timeout: Duration::from_millis(25),
            policy: ResponsePolicy::WholeWindow,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Probe {
    revision: Range,
    serial: Range,
}

const STACK: usize = 66;

fn halves(r: Range) -> (Range, Range) {
    let mid = r.low + (r.high - r.low) / 2;
    (
        Range {
            low: r.low,
            high: mid,
        },
        Range {
            low: mid + 1,
            high: r.high,
        },
    )
}

/// The identify-range scan machine; see the module docs. Output: the addresses found, in
/// ascending (serial, revision) order.
#[derive(Debug, Clone)]
pub struct Slowscan {
    config: SlowscanConfig,
    io: Io<AddressList>,
    stack: Vec<Probe, STACK>,
    current: Option<Probe>,
    found: AddressList,
}

impl Slowscan {
    /// An idle machine.
    pub const fn new(config: SlowscanConfig) -> Self {
        Self {
            config,
            io: Io::new(),
            stack: Vec::new(),
            current: None,
            found: Vec::new(),
        }
    }

    /// Starts the search. Fails with [`LssError::Busy`] while one runs, and with
    /// [`LssError::InvalidConfig`] for an empty range.
    pub fn start(&mut self, now: Instant) -> Result<(), LssError> {
        if self.current.is_some() {
            return Err(LssError::Busy);
        }
        let c = self.config;
        if c.revision.low > c.revision.high || c.serial.low > c.serial.high {
            return Err(LssError::InvalidConfig("empty revision or serial range"));
        }
        self.io.ex.clear();
        self.stack.clear();
        self.found.clear();
        self.io.events.clear();
        self.io.finished = false;
        let _ = self.stack.push(Probe {
            revision: c.revision,
            serial: c.serial,
        });
        self.next(now);
        Ok(())
    }

    fn next(&mut self, now: Instant) {
        let Some(probe) = self.stack.pop() else {
            self.current = None;
            self.io.finished = true;
            self.io.events.finish(Ok(self.found.clone()));
            return;
        };
        let q = IdentifyQuery {
            vendor_id: self.config.vendor_id,
            product_code: self.config.product_code,
            revision: probe.revision,
            serial: probe.serial,
        };
        let [a, b, c, d, e, f] = q.requests();
        for r in [a, b, c, d, e] {
            self.io.ex.send(r);
        }
        let collect = self.config.policy == ResponsePolicy::WholeWindow;
        self.io.ex.ask(
            now,
            f,
            cs::IDENTIFY_SLAVE,
            self.config.response_timeout,
            collect,
        );
        self.current = Some(probe);
    }

    fn fail(&mut self, e: LssError) {
        self.io.ex.clear();
        self.current = None;
        self.io.finished = true;
        self.io.events.finish(Err(e));
    }

    fn react(&mut self, now: Instant, reply: Reply) {
        let Some(p) = self.current.take() else {
            return;
        };
        if let Reply::Answer(_) = reply {
            let split = if p.serial.low < p.serial.high {
                let (lo, hi) = halves(p.serial);
                Some((Probe { serial: hi, ..p }, Probe { serial: lo, ..p }))
            } else if p.revision.low < p.revision.high {
                let (lo, hi) = halves(p.revision);
                Some((Probe { revision: hi, ..p }, Probe { revision: lo, ..p }))
            } else {
                None
            };
            match split {
                Some((later, first)) => {
                    if self.stack.push(later).is_err() || self.stack.push(first).is_err() {
                        // Cannot happen with the depth bound in the module docs.
                        self.fail(LssError::TooMany(STACK));
                        return;
                    }
                }
                None => {
                    let a = LssAddress::new(
                        self.config.vendor_id,
                        self.config.product_code,
                        p.revision.low,
                        p.serial.low,
                    );
                    if self.found.push(a).is_err() {
                        self.fail(LssError::TooMany(MAX_SLAVES));
                        return;
                    }
                    self.io.events.push(MasterEvent::Found(a));
                }
            }
        }
        self.next(now);
    }
}

driven_machine!(Slowscan, AddressList);

impl Driven for Slowscan {
    type Output = AddressList;
    type Progress = core::convert::Infallible;

    fn io(&self) -> &Io<Self::Output, Self::Progress> {
        &self.io
    }

    fn io_mut(&mut self) -> &mut Io<Self::Output, Self::Progress> {
        &mut self.io
    }

    fn on_reply(&mut self, now: Instant, reply: Reply) {
        self.react(now, reply);
    }
}
