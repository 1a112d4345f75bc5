//! LSS Fastscan (CiA 305, added in DSP 305 V2.2): finding the full LSS address of an unconfigured slave by a
//! bit-wise search, and finding every unconfigured slave by repeating it.
//!
//! One scan is the standard search:
//! 1. Bit check 0x80: "is any unconfigured slave in waiting state there?" Every such slave
//!    answers identify slave (0x4F) and resets its scan position to the vendor-ID.
//! 2. For each address part (`LSSSub` = 0 vendor-ID .. 3 serial number) and each bit from 31 down
//!    to 0: send the value found so far with this bit 0 and `BitChecked` = the bit. Slaves whose
//!    bits `BitChecked..=31` equal it answer; silence means the bit is 1. (Among several slaves
//!    this follows the numerically smallest remaining address.)
//! 3. Confirm the part with `BitChecked` = 0 and `LSSNext` = the next part; the matching slaves
//!    move on to that part, the others drop out of this scan. Confirming the serial number with
//!    `LSSNext` = 0 (a part lower than `LSSSub`) puts the one remaining slave into
//!    configuration state.
//!
//! Each part can be searched, known or skipped ([`FastscanConfig::known`],
//! [`FastscanConfig::skip`]; CiA 309-3's scan types 0, 2 and 1 of `lss_allnodes`):
//! - A *known* part (say the vendor-ID of the devices the master commissions) is confirmed
//!   with one request instead of being searched: only slaves with that value are found.
//! - A *skipped* part is never named: the confirmation before it gives the part after it as
//!   `LSSNext`, so the slaves jump over it, and the confirmation of the last part named gives
//!   `LSSNext` = vendor-ID, which selects the slave. Slaves compare only the part named by
//!   `LSSSub`, so a skipped part's value plays no part: slaves that differ only in skipped
//!   parts are one slave to Fastscan, are selected together and must not be on the bus at the
//!   same time if each is to get its own node-ID. A skipped part reads 0 in the address found.
//!   After the bit check every slave compares the vendor-ID first, so the vendor-ID cannot be
//!   skipped, and one part after it must be named to select the slave
//!   ([`FastscanConfig::validate`]).
//!
//! A known part after a searched one cannot steer the search before it: the search follows the
//! smallest value among *all* unconfigured slaves, and the slaves with that value may all have
//! another value in the known part. When the known part's confirmation goes unanswered, the
//! scan goes on as a successor search above the value found so far (see below), limited to the
//! searched parts before the known one. Each group of slaves turned away so costs about one
//! more scan, so a known part is cheapest where it leads.
//!
//! A scan costs 1 + 4 × 33 = 133 exchanges; a known part costs 1 instead of 33, a skipped one
//! none. Every silent exchange costs one response timeout; under
//! [`ResponsePolicy::WholeWindow`] answered ones do too.
//!
//! A found slave is still unconfigured, and real slaves answer Fastscan in configuration state
//! too (CiA 305 ties Fastscan to the slave having no node-ID, and stacks such as CANopenNode
//! check only that), so a found slave cannot be kept out of the next scan by leaving it in
//! configuration state. [`DiscoverAll`] therefore releases each found slave with switch mode
//! global (waiting) and runs the next scan as a *successor search*: the smallest unconfigured
//! address above the last one found. That search confirms the last address's parts up to the
//! last searched part, then asks, from bit 0 upwards, whether a slave shares the last address's
//! higher bits and has a 1 where it has a 0; the first bit with an answer is where the next
//! address first exceeds the last, and the ordinary search for the smallest finishes the
//! address from there. When no bit of a part has an answer, the search moves to the searched
//! part before it (a new bit check, confirming less); known parts are never exceeded and
//! skipped ones are not compared, so both are passed over. Slaves that share the serial
//! number's neighbourhood cost a few exchanges; the worst case is about twice an ordinary
//! scan. Discovery ends when a successor search finds nobody, and finally sends switch mode
//! global (waiting).

use canola_frame::{Duration, Instant};
use heapless::Vec;

use crate::address::{AddressPart, LssAddress};
use crate::error::LssError;
use crate::machine::{Driven, Exchange, Io, MasterEvent, Reply, ResponsePolicy, driven_machine};
use crate::wire::{BIT_CHECK_CONFIRM, Mode, Request, cs};

/// The most slaves a scan result list holds: one per node-ID.
pub const MAX_SLAVES: usize = 127;

/// Timing of Fastscan, and which address parts it searches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FastscanConfig {
    /// How long to wait for identify slave after each Fastscan request.
    pub response_timeout: Duration,
    /// When to move on after an answer.
    pub policy: ResponsePolicy,
    /// Address parts the master already knows (e.g. the vendor-ID of the devices it commissions),
    /// indexed by [`AddressPart::index`]: each is confirmed with one request instead of being
    /// searched bit by bit, saving 32 exchanges per part, and only slaves with these values are
    /// found.
    pub known: [Option<u32>; 4],
    /// Address parts the scan skips, indexed by [`AddressPart::index`]: never named, so their
    /// values do not matter and read 0 in the address found (see the module docs). Not the
    /// vendor-ID, not all three others, and not a known part.
    pub skip: [bool; 4],
}

impl FastscanConfig {
    /// The default response timeout: 25 ms, generous for slaves that answer from a main loop
    /// on a busy bus.
    pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(25);

    /// Checks that the parts to skip leave a scan that selects a slave: the vendor-ID is
    /// named (every slave compares it first after the bit check), so is one part after it
    /// (its confirmation selects the slave), and no part is both known and skipped. Fails with
    /// [`LssError::InvalidConfig`].
    pub fn validate(&self) -> Result<(), LssError> {
        if self.skip[0] {
            return Err(LssError::InvalidConfig(
                "Fastscan cannot skip the vendor-ID: every slave compares it first",
            ));
        }
        if self.skip[1..].iter().all(|s| *s) {
            return Err(LssError::InvalidConfig(
                "Fastscan must name a part after the vendor-ID to select a slave",
            ));
        }
        if self
            .skip
            .iter()
            .zip(&self.known)
            .any(|(s, k)| *s && k.is_some())
        {
            return Err(LssError::InvalidConfig(
                "an address part cannot be both known and skipped",
            ));
        }
        Ok(())
    }

    fn known_value(&self, part: AddressPart) -> Option<u32> {
        self.known[usize::from(part.index())]
    }

    fn named(&self, part: AddressPart) -> bool {
        !self.skip[usize::from(part.index())]
    }

    fn searched(&self, part: AddressPart) -> bool {
        self.named(part) && self.known_value(part).is_none()
    }

    /// The first part after `part` that the scan names; `None` after the last one.
    fn next_named(&self, part: AddressPart) -> Option<AddressPart> {
        AddressPart::ALL[usize::from(part.index()) + 1..]
            .iter()
            .copied()
            .find(|p| self.named(*p))
    }

    /// `LSSNext` of the confirmation of `part`: the next part named, or the vendor-ID after
    /// the last one (which selects the slave).
    fn lss_next(&self, part: AddressPart) -> AddressPart {
        self.next_named(part).unwrap_or(AddressPart::Vendor)
    }

    /// The last searched part before `part`.
    fn searched_before(&self, part: AddressPart) -> Option<AddressPart> {
        AddressPart::ALL[..usize::from(part.index())]
            .iter()
            .rev()
            .copied()
            .find(|p| self.searched(*p))
    }

    /// Where a successor search compares first: the last searched part (the vendor-ID when
    /// every part is known or skipped, where it finds nobody above).
    fn last_searched(&self) -> AddressPart {
        AddressPart::ALL
            .iter()
            .rev()
            .copied()
            .find(|p| self.searched(*p))
            .unwrap_or(AddressPart::Vendor)
    }
}

impl Default for FastscanConfig {
    fn default() -> Self {
        Self {
            response_timeout: Self::DEFAULT_TIMEOUT,
            policy: ResponsePolicy::WholeWindow,
            known: [None; 4],
            skip: [false; 4],
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ScanState {
    Check,
    Bit {
        part: AddressPart,
        bit: u8,
    },
    /// `known`: the value came from the configuration, not from the search.
    Confirm {
        part: AddressPart,
        known: bool,
    },
    /// Successor search: confirming the lower bound's `part` to reach the searched part.
    Position {
        part: AddressPart,
    },
    /// Successor search: does a slave have the lower bound's bits of `part` above `bit`, and
    /// 1 where the bound has 0 at `bit`?
    Above {
        part: AddressPart,
        bit: u8,
    },
}

/// What one step of a scan produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ScanStep {
    Continue,
    Found(LssAddress),
    NoneLeft,
    Lost(AddressPart),
}

/// One Fastscan search, driven by an owning machine over its [`Exchange`]. The owner checks
/// the configuration with [`FastscanConfig::validate`] first.
#[derive(Debug, Clone)]
pub(crate) struct ScanCore {
    state: ScanState,
    address: LssAddress,
    config: FastscanConfig,
    /// Successor search: find the smallest address above this one.
    above: Option<LssAddress>,
    /// Successor search: the searched part in which the found address first exceeds `above`.
    seek: AddressPart,
}

impl ScanCore {
    /// Queues the bit check 0x80 of a scan for the smallest unconfigured address.
    pub(crate) fn start(ex: &mut Exchange, now: Instant, config: FastscanConfig) -> Self {
        Self::scan(ex, now, config, None)
    }

    /// Queues the bit check 0x80 of a scan for the smallest unconfigured address above `last`
    /// (the successor search; see [`DiscoverAll`]).
    pub(crate) fn start_above(
        ex: &mut Exchange,
        now: Instant,
        config: FastscanConfig,
        last: LssAddress,
    ) -> Self {
        Self::scan(ex, now, config, Some(last))
    }

    fn scan(
        ex: &mut Exchange,
        now: Instant,
        config: FastscanConfig,
        above: Option<LssAddress>,
    ) -> Self {
        let mut core = Self {
            state: ScanState::Check,
            address: LssAddress::default(),
            config,
            above,
            seek: config.last_searched(),
        };
        core.check(ex, now);
        core
    }

    fn check(&mut self, ex: &mut Exchange, now: Instant) {
        self.state = ScanState::Check;
        self.ask(
            ex,
            now,
            0,
            BIT_CHECK_CONFIRM,
            AddressPart::Vendor,
            AddressPart::Vendor,
        );
    }

    /// Successor search: moves the slaves that share the bound's named parts before `seek`
    /// on to `seek`, confirming from `part` (a named part) on.
    fn position(
        &mut self,
        ex: &mut Exchange,
        now: Instant,
        bound: LssAddress,
        part: AddressPart,
    ) -> ScanStep {
        if part == self.seek {
            return self.above_from(ex, now, bound, part, 0);
        }
        self.state = ScanState::Position { part };
        let next = self.config.lss_next(part);
        self.ask(ex, now, bound.get(part), 0, part, next);
        ScanStep::Continue
    }

    /// Successor search: asks about the lowest bit `>= from` of `part` where the bound has 0.
    fn above_from(
        &mut self,
        ex: &mut Exchange,
        now: Instant,
        bound: LssAddress,
        part: AddressPart,
        from: u8,
    ) -> ScanStep {
        if !self.config.searched(part) {
            // A known part is never exceeded: look in the searched part before it.
            return self.seek_up(ex, now, part);
        }
        let value = bound.get(part);
        match (from..32).find(|b| value & (1u32 << b) == 0) {
            Some(bit) => {
                self.state = ScanState::Above { part, bit };
                let id_number = (value & (u32::MAX << bit)) | (1u32 << bit);
                self.ask(ex, now, id_number, bit, part, part);
                ScanStep::Continue
            }
            None => self.seek_up(ex, now, part),
        }
    }

    /// Successor search: nobody exceeds the bound in `part`; try the searched part before
    /// it, from a new bit check (the slaves' scan positions have moved past it).
    fn seek_up(&mut self, ex: &mut Exchange, now: Instant, part: AddressPart) -> ScanStep {
        match self.config.searched_before(part) {
            Some(before) => {
                self.seek = before;
                self.check(ex, now);
                ScanStep::Continue
            }
            None => ScanStep::NoneLeft,
        }
    }

    fn ask(
        &self,
        ex: &mut Exchange,
        now: Instant,
        id_number: u32,
        bit_check: u8,
        sub: AddressPart,
        next: AddressPart,
    ) {
        let req = Request::Fastscan {
            id_number,
            bit_check,
            lss_sub: sub.index(),
            lss_next: next.index(),
        };
        let collect = self.config.policy == ResponsePolicy::WholeWindow;
        ex.ask(
            now,
            req,
            cs::IDENTIFY_SLAVE,
            self.config.response_timeout,
            collect,
        );
    }

    /// Starts on `part` (a named part): confirms a known value at once, or searches from
    /// bit 31.
    fn begin_part(&mut self, ex: &mut Exchange, now: Instant, part: AddressPart) {
        match self.config.known_value(part) {
            Some(value) => {
                self.address.set(part, value);
                self.confirm(ex, now, part, true);
            }
            None => self.ask_bit(ex, now, part, 31),
        }
    }

    fn ask_bit(&mut self, ex: &mut Exchange, now: Instant, part: AddressPart, bit: u8) {
        self.state = ScanState::Bit { part, bit };
        let value = self.address.get(part);
        self.ask(ex, now, value, bit, part, part);
    }

    /// Confirms the value of `part` found so far, moving the matching slaves on to the next
    /// part named (or selecting them after the last).
    fn confirm(&mut self, ex: &mut Exchange, now: Instant, part: AddressPart, known: bool) {
        self.state = ScanState::Confirm { part, known };
        let value = self.address.get(part);
        let next = self.config.lss_next(part);
        self.ask(ex, now, value, 0, part, next);
    }

    /// Advances on the reply to the last request.
    pub(crate) fn step(&mut self, ex: &mut Exchange, now: Instant, reply: Reply) -> ScanStep {
        let answered = matches!(reply, Reply::Answer(_));
        match self.state {
            ScanState::Check => {
                if !answered {
                    return ScanStep::NoneLeft;
                }
                match self.above {
                    Some(bound) => return self.position(ex, now, bound, AddressPart::Vendor),
                    None => self.begin_part(ex, now, AddressPart::Vendor),
                }
            }
            ScanState::Position { part } => {
                let Some(bound) = self.above else {
                    return ScanStep::NoneLeft;
                };
                if !answered {
                    // Nobody shares the bound's `part`: the slaves that share the parts
                    // before it still sit at `part`, so the search continues there.
                    self.seek = part;
                    return self.above_from(ex, now, bound, part, 0);
                }
                let next = self.config.lss_next(part);
                return self.position(ex, now, bound, next);
            }
            ScanState::Above { part, bit } => {
                let Some(bound) = self.above else {
                    return ScanStep::NoneLeft;
                };
                if !answered {
                    return self.above_from(ex, now, bound, part, bit + 1);
                }
                // The smallest address above the bound starts here: the bound's earlier
                // parts, this part's higher bits and a 1 at `bit`; the rest is the ordinary
                // search for the smallest.
                self.above = None;
                self.address = LssAddress::default();
                for p in AddressPart::ALL.iter().take_while(|p| **p != part) {
                    self.address.set(*p, bound.get(*p));
                }
                let value = (bound.get(part) & (u32::MAX << bit)) | (1u32 << bit);
                self.address.set(part, value);
                if bit == 0 {
                    self.confirm(ex, now, part, false);
                } else {
                    self.ask_bit(ex, now, part, bit - 1);
                }
            }
            ScanState::Bit { part, bit } => {
                if !answered {
                    // Nobody has this bit 0 (with the higher bits found so far): it is 1.
                    let value = self.address.get(part) | (1u32 << (bit & 31));
                    self.address.set(part, value);
                }
                if bit == 0 {
                    self.confirm(ex, now, part, false);
                } else {
                    self.ask_bit(ex, now, part, bit - 1);
                }
            }
            ScanState::Confirm { part, known } => {
                if !answered {
                    if !known {
                        // A searched value that nobody confirms: the slave went away.
                        return ScanStep::Lost(part);
                    }
                    // No slave with the value found so far has the known value: every
                    // wanted slave lies above it in a searched part before this one.
                    let Some(before) = self.config.searched_before(part) else {
                        return ScanStep::NoneLeft;
                    };
                    self.above = Some(self.address);
                    self.seek = before;
                    self.address = LssAddress::default();
                    self.check(ex, now);
                    return ScanStep::Continue;
                }
                match self.config.next_named(part) {
                    Some(next) => self.begin_part(ex, now, next),
                    None => return ScanStep::Found(self.address),
                }
            }
        }
        ScanStep::Continue
    }
}

/// Finds one unconfigured slave by Fastscan and leaves it in configuration state.
///
/// Output: `Some(address)` (the smallest with the known values; skipped parts 0), or `None`
/// when no unconfigured slave answered the bit check or none has the known values.
#[derive(Debug, Clone)]
pub struct Fastscan {
    io: Io<Option<LssAddress>>,
    core: Option<ScanCore>,
    config: FastscanConfig,
}

impl Fastscan {
    /// An idle machine.
    pub const fn new(config: FastscanConfig) -> Self {
        Self {
            io: Io::new(),
            core: None,
            config,
        }
    }

    /// Starts a scan. Fails with [`LssError::Busy`] while one runs, and with
    /// [`LssError::InvalidConfig`] for parts to skip that leave no scan
    /// ([`FastscanConfig::validate`]).
    pub fn start(&mut self, now: Instant) -> Result<(), LssError> {
        if self.core.is_some() {
            return Err(LssError::Busy);
        }
        self.config.validate()?;
        self.io.ex.clear();
        self.io.events.clear();
        self.io.finished = false;
        self.core = Some(ScanCore::start(&mut self.io.ex, now, self.config));
        Ok(())
    }

    fn react(&mut self, now: Instant, reply: Reply) {
        let Some(core) = self.core.as_mut() else {
            return;
        };
        let result = match core.step(&mut self.io.ex, now, reply) {
            ScanStep::Continue => return,
            ScanStep::Found(a) => {
                self.io.events.push(MasterEvent::Found(a));
                Ok(Some(a))
            }
            ScanStep::NoneLeft => Ok(None),
            ScanStep::Lost(part) => Err(LssError::FastscanLost { part }),
        };
        self.core = None;
        self.io.finished = true;
        self.io.events.finish(result);
    }
}

driven_machine!(Fastscan, Option<LssAddress>);

impl Driven for Fastscan {
    type Output = Option<LssAddress>;
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

/// The slaves [`DiscoverAll`] found, in the order found.
pub type AddressList = Vec<LssAddress, MAX_SLAVES>;

/// Finds every unconfigured slave by repeated Fastscan, without configuring any; see the module
/// docs. Starts and ends with switch mode global (waiting), so the slaves are back where they
/// started. Works whether or not the slaves answer Fastscan in configuration state.
///
/// Output: the addresses found. A scan that loses its slave ends the machine with
/// [`LssError::FastscanLost`]; more than [`MAX_SLAVES`] slaves with [`LssError::TooMany`]
/// (switch mode global waiting is sent in both cases).
#[derive(Debug, Clone)]
pub struct DiscoverAll {
    io: Io<AddressList>,
    core: Option<ScanCore>,
    config: FastscanConfig,
    found: AddressList,
}

impl DiscoverAll {
    /// An idle machine.
    pub const fn new(config: FastscanConfig) -> Self {
        Self {
            io: Io::new(),
            core: None,
            config,
            found: Vec::new(),
        }
    }

    /// Starts discovery. Fails with [`LssError::Busy`] while one runs, and with
    /// [`LssError::InvalidConfig`] for parts to skip that leave no scan
    /// ([`FastscanConfig::validate`]).
    pub fn start(&mut self, now: Instant) -> Result<(), LssError> {
        if self.core.is_some() {
            return Err(LssError::Busy);
        }
        self.config.validate()?;
        self.io.ex.clear();
        self.found.clear();
        self.io.events.clear();
        self.io.finished = false;
        // No slave left in configuration state by an earlier session may skew the scan.
        self.io.ex.send(Request::SwitchModeGlobal(Mode::Waiting));
        self.core = Some(ScanCore::start(&mut self.io.ex, now, self.config));
        Ok(())
    }

    fn finish(&mut self, result: Result<(), LssError>) {
        self.core = None;
        self.io.finished = true;
        self.io.ex.send(Request::SwitchModeGlobal(Mode::Waiting));
        self.io.events.finish(result.map(|()| self.found.clone()));
    }

    fn react(&mut self, now: Instant, reply: Reply) {
        let Some(core) = self.core.as_mut() else {
            return;
        };
        match core.step(&mut self.io.ex, now, reply) {
            ScanStep::Continue => {}
            ScanStep::Found(a) => {
                if self.found.push(a).is_err() {
                    self.finish(Err(LssError::TooMany(MAX_SLAVES)));
                    return;
                }
                self.io.events.push(MasterEvent::Found(a));
                // Release the found slave (it may answer Fastscan in configuration state as
                // well) and look for the next address above it.
                self.io.ex.send(Request::SwitchModeGlobal(Mode::Waiting));
                self.core = Some(ScanCore::start_above(&mut self.io.ex, now, self.config, a));
            }
            ScanStep::NoneLeft => self.finish(Ok(())),
            ScanStep::Lost(part) => self.finish(Err(LssError::FastscanLost { part })),
        }
    }
}

driven_machine!(DiscoverAll, AddressList);

impl Driven for DiscoverAll {
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
