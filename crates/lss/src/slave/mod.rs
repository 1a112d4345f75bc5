//! The LSS slave (CiA 305: the LSS slave state machine and the slave side of the LSS protocols), sans-IO, for the
//! device simulator.
//!
//! States: **waiting** (the power-on state; answers switch mode selective, identify and
//! Fastscan) and **configuration** (entered by switch mode global 1, a matched switch mode
//! selective or a completed Fastscan; answers configure, store, inquire and activate).
//!
//! Node-ID and bit timing each exist twice. Configure node-ID and configure bit timing set the
//! *pending* value; the pending node-ID becomes *active* on NMT reset communication
//! ([`LssSlave::reset_communication`]) or, for a slave that had no node-ID, when it is switched
//! back to waiting state (it then reports [`SlaveEvent::ResetCommunication`] so the simulator
//! restarts its communication with the new node-ID). The pending bit timing becomes active with
//! activate bit timing: after the switch delay the slave reports [`SlaveEvent::SwitchBitRate`],
//! and after a second delay it resumes answering. Store configuration reports
//! [`SlaveEvent::StoreConfiguration`] with the pending values for the application to persist.
//!
//! Files by concern: this one holds the configuration, the states and events and the services
//! of configuration state (configure, store, inquire, activate bit timing); `addressing` how a
//! slave in waiting state is picked out: switch mode selective, identify remote slave and the
//! Fastscan responder.

mod addressing;

use canola_frame::{CanFrame, Instant, NodeId};
use heapless::Deque;

use crate::address::{BitTiming, LssAddress};
use crate::wire::{ConfigStatus, Mode, Request, Response, ResponseError, UNCONFIGURED_NODE_ID};

/// The LSS state of a slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlaveState {
    /// LSS waiting state.
    Waiting,
    /// LSS configuration state.
    Configuration,
}

/// How the slave answers store configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum StoreSupport {
    /// Success; reports [`SlaveEvent::StoreConfiguration`].
    #[default]
    Supported,
    /// Error 1: store configuration is not supported.
    NotSupported,
    /// Error 2: storage media access error.
    MediaError,
    /// Error 255 with this manufacturer-specific extension.
    Vendor(u8),
}

/// What the simulated device is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlaveConfig {
    /// Its LSS address (object 0x1018).
    pub address: LssAddress,
    /// The node-ID it starts with (stored), or [`UNCONFIGURED_NODE_ID`].
    pub node_id: u8,
    /// The bit timing it starts with.
    pub bit_timing: BitTiming,
    /// Bit mask of the CiA table (table 0) indexes it supports; other tables are refused.
    pub bit_rates: u16,
    /// How it answers store configuration.
    pub store: StoreSupport,
    /// If set, configure node-ID is refused with error 255 and this extension (to exercise
    /// the master's vendor-specific error path).
    pub node_id_vendor_error: Option<u8>,
    /// Whether the slave takes part in Fastscan in configuration state too, as long as it has
    /// no node-ID (active or pending). Real slaves do (CiA 305 ties Fastscan to the missing
    /// node-ID; CANopenNode's slave, for one, checks only that); when unset the slave answers
    /// Fastscan in waiting state only.
    pub fastscan_in_configuration: bool,
}

impl SlaveConfig {
    /// An unconfigured slave at 500 kbit/s that supports table 0 indexes 0..=8 and store.
    pub const fn unconfigured(address: LssAddress) -> Self {
        Self {
            address,
            node_id: UNCONFIGURED_NODE_ID,
            bit_timing: BitTiming { table: 0, index: 2 },
            bit_rates: 0x01FF,
            store: StoreSupport::Supported,
            node_id_vendor_error: None,
            fastscan_in_configuration: false,
        }
    }

    /// [`unconfigured`](Self::unconfigured), answering Fastscan in configuration state too,
    /// as real slaves do.
    pub const fn unconfigured_real(address: LssAddress) -> Self {
        let mut c = Self::unconfigured(address);
        c.fastscan_in_configuration = true;
        c
    }
}

/// What the slave reports to its application.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SlaveEvent {
    /// The LSS state changed.
    StateChanged(SlaveState),
    /// Store configuration succeeded: persist these (pending) values.
    StoreConfiguration {
        /// Pending node-ID (0xFF = unconfigured).
        node_id: u8,
        /// Pending bit timing.
        bit_timing: BitTiming,
    },
    /// Activate bit timing: switch the CAN controller to this bit timing now.
    SwitchBitRate(BitTiming),
    /// A previously unconfigured slave got a node-ID and left configuration state: it has made
    /// the node-ID active; the application performs NMT reset communication with it.
    ResetCommunication {
        /// The new active node-ID.
        node_id: NodeId,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Activation {
    timing: BitTiming,
    switch_at: Instant,
    resume_at: Instant,
    switched: bool,
}

/// An LSS slave. Call order: [`handle_request`](Self::handle_request) (or
/// [`handle_frame`](Self::handle_frame)) for every frame on 0x7E5,
/// [`handle_timeout`](Self::handle_timeout) when [`poll_timeout`](Self::poll_timeout) is due,
/// then drain [`poll_transmit`](Self::poll_transmit) (frames for 0x7E4) and
/// [`poll_event`](Self::poll_event).
#[derive(Debug, Clone)]
pub struct LssSlave {
    config: SlaveConfig,
    state: SlaveState,
    active_node_id: u8,
    pending_node_id: u8,
    active_bit_timing: BitTiming,
    pending_bit_timing: BitTiming,
    /// Switch mode selective: how many parts matched in order.
    selective: u8,
    /// Identify remote slave: how many fields matched in order.
    identify: u8,
    /// Fastscan: the address part compared next.
    fastscan_pos: u8,
    activation: Option<Activation>,
    tx: Deque<Response, 4>,
    events: Deque<SlaveEvent, 4>,
}

impl LssSlave {
    /// A slave just after power-on, in waiting state.
    pub fn new(config: SlaveConfig) -> Self {
        Self {
            config,
            state: SlaveState::Waiting,
            active_node_id: config.node_id,
            pending_node_id: config.node_id,
            active_bit_timing: config.bit_timing,
            pending_bit_timing: config.bit_timing,
            selective: 0,
            identify: 0,
            fastscan_pos: 0,
            activation: None,
            tx: Deque::new(),
            events: Deque::new(),
        }
    }

    /// Its LSS address.
    pub fn address(&self) -> LssAddress {
        self.config.address
    }

    /// The LSS state.
    pub fn state(&self) -> SlaveState {
        self.state
    }

    /// The active node-ID (0xFF = unconfigured).
    pub fn active_node_id(&self) -> u8 {
        self.active_node_id
    }

    /// The pending node-ID (0xFF = unconfigured).
    pub fn pending_node_id(&self) -> u8 {
        self.pending_node_id
    }

    /// The active bit timing.
    pub fn active_bit_timing(&self) -> BitTiming {
        self.active_bit_timing
    }

    /// The pending bit timing.
    pub fn pending_bit_timing(&self) -> BitTiming {
        self.pending_bit_timing
    }

    /// Whether the slave has neither an active nor a pending node-ID (what Fastscan and
    /// identify non-configured remote slave look for).
    pub fn is_unconfigured(&self) -> bool {
        self.active_node_id == UNCONFIGURED_NODE_ID && self.pending_node_id == UNCONFIGURED_NODE_ID
    }

    /// NMT reset communication: the pending node-ID becomes active.
    pub fn reset_communication(&mut self) {
        self.active_node_id = self.pending_node_id;
    }

    /// A received frame: LSS requests (data frames on 0x7E5) are handled, anything else is
    /// ignored. Returns whether it was an LSS request.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) -> bool {
        match Request::from_frame(frame) {
            Ok(r) => {
                self.handle_request(now, &r);
                true
            }
            Err(_) => false,
        }
    }

    /// Time passed (bit timing activation).
    pub fn handle_timeout(&mut self, now: Instant) {
        let Some(mut act) = self.activation else {
            return;
        };
        if !act.switched && now >= act.switch_at {
            act.switched = true;
            self.active_bit_timing = act.timing;
            self.event(SlaveEvent::SwitchBitRate(act.timing));
        }
        self.activation = if act.switched && now >= act.resume_at {
            None
        } else {
            Some(act)
        };
    }

    /// When [`handle_timeout`](Self::handle_timeout) is due.
    pub fn poll_timeout(&self) -> Option<Instant> {
        self.activation
            .map(|a| if a.switched { a.resume_at } else { a.switch_at })
    }

    /// The next response to send on 0x7E4.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<Response> {
        self.tx.pop_front()
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame.
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|r| r.to_frame())
    }

    /// The next event for the application.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<SlaveEvent> {
        self.events.pop_front()
    }

    fn event(&mut self, e: SlaveEvent) {
        if self.events.is_full() {
            let _ = self.events.pop_front();
        }
        let _ = self.events.push_back(e);
    }

    fn answer(&mut self, r: Response) {
        if self.tx.is_full() {
            let _ = self.tx.pop_front();
        }
        let _ = self.tx.push_back(r);
    }

    fn enter(&mut self, state: SlaveState) {
        if self.state != state {
            self.state = state;
            self.event(SlaveEvent::StateChanged(state));
        }
    }

    /// A request received on 0x7E5.
    pub fn handle_request(&mut self, now: Instant, req: &Request) {
        self.handle_timeout(now);
        if self.activation.is_some() {
            // Between activate bit timing and the end of the second delay the slave is
            // switching bit rates and takes no part in LSS.
            return;
        }
        // A selective or identify sequence is only continued by its next message.
        if !matches!(req, Request::SwitchModeSelective(..)) {
            self.selective = 0;
        }
        if !matches!(req, Request::IdentifyRemoteSlave(..)) {
            self.identify = 0;
        }
        let configuring = self.state == SlaveState::Configuration;
        match *req {
            Request::SwitchModeGlobal(Mode::Configuration) => self.enter(SlaveState::Configuration),
            Request::SwitchModeGlobal(Mode::Waiting) => self.enter_waiting(),
            Request::SwitchModeGlobal(Mode::Unknown(_)) => {}
            Request::SwitchModeSelective(part, value) => self.selective(part, value),
            Request::IdentifyRemoteSlave(field, value) => self.identify(field, value),
            Request::IdentifyNonConfigured if self.is_unconfigured() => {
                self.answer(Response::IdentifyNonConfiguredSlave);
            }
            Request::Fastscan {
                id_number,
                bit_check,
                lss_sub,
                lss_next,
            } => self.fastscan(id_number, bit_check, lss_sub, lss_next),
            Request::ConfigureNodeId(id) if configuring => {
                let status = if let Some(ext) = self.config.node_id_vendor_error {
                    ConfigStatus::from_error(ResponseError::VendorSpecific(ext))
                } else if id == UNCONFIGURED_NODE_ID || NodeId::new(id).is_ok() {
                    self.pending_node_id = id;
                    ConfigStatus::OK
                } else {
                    ConfigStatus::from_error(ResponseError::NotSupported)
                };
                self.answer(Response::ConfigureNodeId(status));
            }
            Request::ConfigureBitTiming(t) if configuring => {
                let supported = t.table == BitTiming::CIA_TABLE
                    && t.index < 16
                    && self.config.bit_rates & (1 << t.index) != 0;
                let status = if supported {
                    self.pending_bit_timing = t;
                    ConfigStatus::OK
                } else {
                    ConfigStatus::from_error(ResponseError::NotSupported)
                };
                self.answer(Response::ConfigureBitTiming(status));
            }
            Request::ActivateBitTiming { delay_ms } if configuring => {
                let delay = canola_frame::Duration::from_millis(u64::from(delay_ms));
                self.activation = Some(Activation {
                    timing: self.pending_bit_timing,
                    switch_at: now + delay,
                    resume_at: now + delay + delay,
                    switched: false,
                });
                self.handle_timeout(now);
            }
            Request::StoreConfiguration if configuring => {
                let status = match self.config.store {
                    StoreSupport::Supported => {
                        self.event(SlaveEvent::StoreConfiguration {
                            node_id: self.pending_node_id,
                            bit_timing: self.pending_bit_timing,
                        });
                        ConfigStatus::OK
                    }
                    StoreSupport::NotSupported => {
                        ConfigStatus::from_error(ResponseError::NotSupported)
                    }
                    StoreSupport::MediaError => {
                        ConfigStatus::from_error(ResponseError::StorageMediaAccess)
                    }
                    StoreSupport::Vendor(e) => {
                        ConfigStatus::from_error(ResponseError::VendorSpecific(e))
                    }
                };
                self.answer(Response::StoreConfiguration(status));
            }
            Request::InquireIdentity(part) if configuring => {
                self.answer(Response::InquireIdentity(
                    part,
                    self.config.address.get(part),
                ));
            }
            Request::InquireNodeId if configuring => {
                self.answer(Response::InquireNodeId(self.active_node_id));
            }
            // Configuration services outside configuration state, and unknown services.
            _ => {}
        }
    }

    fn enter_waiting(&mut self) {
        if self.state == SlaveState::Waiting {
            return;
        }
        self.enter(SlaveState::Waiting);
        if self.active_node_id == UNCONFIGURED_NODE_ID
            && let Ok(id) = NodeId::new(self.pending_node_id)
        {
            self.active_node_id = id.get();
            self.event(SlaveEvent::ResetCommunication { node_id: id });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::address::{AddressPart, BitRate};
    use crate::wire::IdentifyField;

    const ADDR: LssAddress = LssAddress::new(0x78, 0x1234, 2, 0xCAFE);
    const T: Instant = Instant::ZERO;

    fn slave() -> LssSlave {
        LssSlave::new(SlaveConfig::unconfigured(ADDR))
    }

    fn send(s: &mut LssSlave, r: Request) -> Option<Response> {
        s.handle_request(T, &r);
        s.poll_transmit()
    }

    #[test]
    fn configuration_services_need_configuration_state() {
        let mut s = slave();
        assert_eq!(send(&mut s, Request::ConfigureNodeId(5)), None);
        assert_eq!(send(&mut s, Request::InquireNodeId), None);
        assert_eq!(
            send(&mut s, Request::SwitchModeGlobal(Mode::Configuration)),
            None
        );
        assert_eq!(
            s.poll_event(),
            Some(SlaveEvent::StateChanged(SlaveState::Configuration))
        );
        assert_eq!(
            send(&mut s, Request::ConfigureNodeId(0)),
            Some(Response::ConfigureNodeId(ConfigStatus {
                code: 1,
                extension: 0
            }))
        );
        assert_eq!(
            send(&mut s, Request::ConfigureNodeId(128)),
            Some(Response::ConfigureNodeId(ConfigStatus {
                code: 1,
                extension: 0
            }))
        );
        assert_eq!(
            send(&mut s, Request::ConfigureNodeId(5)),
            Some(Response::ConfigureNodeId(ConfigStatus::OK))
        );
        assert_eq!((s.pending_node_id(), s.active_node_id()), (5, 0xFF));
        assert_eq!(
            send(&mut s, Request::InquireNodeId),
            Some(Response::InquireNodeId(0xFF))
        );
        assert_eq!(
            send(&mut s, Request::InquireIdentity(AddressPart::Serial)),
            Some(Response::InquireIdentity(AddressPart::Serial, 0xCAFE))
        );
        // Leaving configuration with a new node-ID activates it.
        assert_eq!(send(&mut s, Request::SwitchModeGlobal(Mode::Waiting)), None);
        assert_eq!(
            s.poll_event(),
            Some(SlaveEvent::StateChanged(SlaveState::Waiting))
        );
        assert_eq!(
            s.poll_event(),
            Some(SlaveEvent::ResetCommunication {
                node_id: NodeId::new(5).unwrap()
            })
        );
        assert_eq!(s.active_node_id(), 5);
        assert!(!s.is_unconfigured());
    }

    #[test]
    fn configured_slave_keeps_pending_until_reset_communication() {
        let mut cfg = SlaveConfig::unconfigured(ADDR);
        cfg.node_id = 9;
        let mut s = LssSlave::new(cfg);
        let _ = send(&mut s, Request::SwitchModeGlobal(Mode::Configuration));
        let _ = send(&mut s, Request::ConfigureNodeId(10));
        let _ = send(&mut s, Request::SwitchModeGlobal(Mode::Waiting));
        assert_eq!((s.pending_node_id(), s.active_node_id()), (10, 9));
        s.reset_communication();
        assert_eq!(s.active_node_id(), 10);
    }

    #[test]
    fn bit_timing_pending_then_active_after_delays() {
        let mut s = slave();
        let _ = send(&mut s, Request::SwitchModeGlobal(Mode::Configuration));
        assert_eq!(
            send(
                &mut s,
                Request::ConfigureBitTiming(BitTiming { table: 1, index: 0 })
            ),
            Some(Response::ConfigureBitTiming(ConfigStatus {
                code: 1,
                extension: 0
            }))
        );
        assert_eq!(
            send(&mut s, Request::ConfigureBitTiming(BitRate::Auto.into())),
            Some(Response::ConfigureBitTiming(ConfigStatus {
                code: 1,
                extension: 0
            })),
            "index 9 is not in the default mask"
        );
        assert_eq!(
            send(&mut s, Request::ConfigureBitTiming(BitRate::Kbit125.into())),
            Some(Response::ConfigureBitTiming(ConfigStatus::OK))
        );
        assert_eq!(s.active_bit_timing(), BitRate::Kbit500.into());
        assert_eq!(s.pending_bit_timing(), BitRate::Kbit125.into());
        s.handle_request(T, &Request::ActivateBitTiming { delay_ms: 10 });
        assert_eq!(s.poll_timeout(), Some(Instant::from_millis(10)));
        s.handle_timeout(Instant::from_millis(9));
        assert_eq!(s.active_bit_timing(), BitRate::Kbit500.into());
        s.handle_timeout(Instant::from_millis(10));
        assert_eq!(s.active_bit_timing(), BitRate::Kbit125.into());
        let _ = s.poll_event();
        assert_eq!(
            s.poll_event(),
            Some(SlaveEvent::SwitchBitRate(BitRate::Kbit125.into()))
        );
        assert_eq!(s.poll_timeout(), Some(Instant::from_millis(20)));
        // Silent until the second delay is over.
        s.handle_request(Instant::from_millis(15), &Request::InquireNodeId);
        assert_eq!(s.poll_transmit(), None);
        s.handle_request(Instant::from_millis(20), &Request::InquireNodeId);
        assert_eq!(s.poll_transmit(), Some(Response::InquireNodeId(0xFF)));
        assert_eq!(s.poll_timeout(), None);
    }

    #[test]
    fn selective_switch_needs_all_four_in_order() {
        let mut s = slave();
        let parts = [
            (AddressPart::Vendor, 0x78),
            (AddressPart::Product, 0x1234),
            (AddressPart::Revision, 2),
            (AddressPart::Serial, 0xCAFE),
        ];
        // Wrong product: no switch.
        for (p, v) in parts {
            let v = if p == AddressPart::Product { v + 1 } else { v };
            assert_eq!(send(&mut s, Request::SwitchModeSelective(p, v)), None);
        }
        assert_eq!(s.state(), SlaveState::Waiting);
        // Serial alone: no switch.
        assert_eq!(
            send(
                &mut s,
                Request::SwitchModeSelective(AddressPart::Serial, 0xCAFE)
            ),
            None
        );
        for (i, (p, v)) in parts.into_iter().enumerate() {
            let r = send(&mut s, Request::SwitchModeSelective(p, v));
            assert_eq!(r, (i == 3).then_some(Response::SwitchModeSelective));
        }
        assert_eq!(s.state(), SlaveState::Configuration);
    }

    #[test]
    fn identify_remote_ranges() {
        let probe = |s: &mut LssSlave, v, p, rl, rh, sl, sh| {
            let vals = [v, p, rl, rh, sl, sh];
            let mut last = None;
            for (f, x) in IdentifyField::ALL.iter().zip(vals) {
                last = send(s, Request::IdentifyRemoteSlave(*f, x));
            }
            last == Some(Response::IdentifySlave)
        };
        let mut s = slave();
        assert!(probe(&mut s, 0x78, 0x1234, 0, u32::MAX, 0, u32::MAX));
        assert!(probe(&mut s, 0x78, 0x1234, 2, 2, 0xCAFE, 0xCAFE));
        assert!(!probe(&mut s, 0x78, 0x1234, 3, 9, 0, u32::MAX));
        assert!(!probe(&mut s, 0x78, 0x1234, 0, 9, 0xCAFF, u32::MAX));
        assert!(!probe(&mut s, 0x79, 0x1234, 0, 9, 0, u32::MAX));
        // Also in configuration state and when configured.
        let _ = send(&mut s, Request::SwitchModeGlobal(Mode::Configuration));
        assert!(probe(&mut s, 0x78, 0x1234, 0, 9, 0, u32::MAX));
        assert_eq!(
            send(&mut s, Request::IdentifyNonConfigured),
            Some(Response::IdentifyNonConfiguredSlave)
        );
        let _ = send(&mut s, Request::ConfigureNodeId(3));
        assert_eq!(send(&mut s, Request::IdentifyNonConfigured), None);
    }

    #[test]
    fn fastscan_responder() {
        let mut s = slave();
        let fs = |id, bit, sub, next| Request::Fastscan {
            id_number: id,
            bit_check: bit,
            lss_sub: sub,
            lss_next: next,
        };
        assert_eq!(
            send(&mut s, fs(0, 0x80, 0, 0)),
            Some(Response::IdentifySlave)
        );
        // Invalid fields: silence.
        assert_eq!(send(&mut s, fs(0, 0x81, 0, 0)), None);
        assert_eq!(send(&mut s, fs(0, 32, 0, 0)), None);
        assert_eq!(send(&mut s, fs(0, 31, 4, 0)), None);
        assert_eq!(send(&mut s, fs(0, 31, 0, 4)), None);
        // Vendor 0x78: bit 31 = 0 matches; bits 6..=31 compared with 0 differ (bit 6 set).
        assert_eq!(send(&mut s, fs(0, 31, 0, 0)), Some(Response::IdentifySlave));
        assert_eq!(send(&mut s, fs(0, 6, 0, 0)), None);
        assert_eq!(
            send(&mut s, fs(0x40, 6, 0, 0)),
            Some(Response::IdentifySlave)
        );
        // Wrong LSSSub for the current position: silence.
        assert_eq!(send(&mut s, fs(0x1234, 0, 1, 2)), None);
        assert_eq!(
            send(&mut s, fs(0x78, 0, 0, 1)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(
            send(&mut s, fs(0x1234, 0, 1, 2)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(send(&mut s, fs(2, 0, 2, 3)), Some(Response::IdentifySlave));
        assert_eq!(s.state(), SlaveState::Waiting);
        assert_eq!(
            send(&mut s, fs(0xCAFE, 0, 3, 0)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(s.state(), SlaveState::Configuration);
        // In configuration state it no longer takes part.
        assert_eq!(send(&mut s, fs(0, 0x80, 0, 0)), None);
        // A configured slave never answers.
        let _ = send(&mut s, Request::ConfigureNodeId(4));
        let _ = send(&mut s, Request::SwitchModeGlobal(Mode::Waiting));
        assert_eq!(send(&mut s, fs(0, 0x80, 0, 0)), None);
    }

    #[test]
    fn fastscan_lss_next_jumps_over_parts() {
        let mut s = slave();
        let fs = |id, bit, sub, next| Request::Fastscan {
            id_number: id,
            bit_check: bit,
            lss_sub: sub,
            lss_next: next,
        };
        assert_eq!(
            send(&mut s, fs(0, 0x80, 0, 0)),
            Some(Response::IdentifySlave)
        );
        // The vendor-ID's confirmation names the revision number: the product code is never
        // compared, whatever is sent for it.
        assert_eq!(
            send(&mut s, fs(0x78, 0, 0, 2)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(send(&mut s, fs(0x1234, 0, 1, 2)), None);
        assert_eq!(send(&mut s, fs(0, 31, 1, 1)), None);
        // The revision number is compared from its highest bits down.
        assert_eq!(send(&mut s, fs(3, 1, 2, 2)), Some(Response::IdentifySlave));
        assert_eq!(send(&mut s, fs(3, 0, 2, 2)), None);
        // Confirming it with LSSNext = vendor-ID (below LSSSub) selects the slave: the serial
        // number is skipped too.
        assert_eq!(s.state(), SlaveState::Waiting);
        assert_eq!(send(&mut s, fs(2, 0, 2, 0)), Some(Response::IdentifySlave));
        assert_eq!(s.state(), SlaveState::Configuration);
        // A confirmation with LSSNext above LSSSub never selects.
        let mut s = slave();
        let _ = send(&mut s, fs(0, 0x80, 0, 0));
        let _ = send(&mut s, fs(0x78, 0, 0, 3));
        assert_eq!(
            send(&mut s, fs(0xCAFE, 0, 3, 3)),
            Some(Response::IdentifySlave)
        );
        assert_eq!(s.state(), SlaveState::Waiting);
    }

    #[test]
    fn real_slave_answers_fastscan_in_configuration_until_configured() {
        let mut s = LssSlave::new(SlaveConfig::unconfigured_real(ADDR));
        let confirm = Request::Fastscan {
            id_number: 0,
            bit_check: 0x80,
            lss_sub: 0,
            lss_next: 0,
        };
        let _ = send(&mut s, Request::SwitchModeGlobal(Mode::Configuration));
        assert_eq!(send(&mut s, confirm), Some(Response::IdentifySlave));
        // Configured but still in configuration state: the pending node-ID silences it.
        let _ = send(&mut s, Request::ConfigureNodeId(4));
        assert_eq!(s.state(), SlaveState::Configuration);
        assert_eq!(send(&mut s, confirm), None);
        // Unconfigured again (node-ID 0xFF): it answers again, still in configuration state.
        let _ = send(&mut s, Request::ConfigureNodeId(0xFF));
        assert_eq!(send(&mut s, confirm), Some(Response::IdentifySlave));
    }

    #[test]
    fn store_answers() {
        for (support, status) in [
            (StoreSupport::Supported, ConfigStatus::OK),
            (
                StoreSupport::NotSupported,
                ConfigStatus {
                    code: 1,
                    extension: 0,
                },
            ),
            (
                StoreSupport::MediaError,
                ConfigStatus {
                    code: 2,
                    extension: 0,
                },
            ),
            (
                StoreSupport::Vendor(0x5A),
                ConfigStatus {
                    code: 255,
                    extension: 0x5A,
                },
            ),
        ] {
            let mut cfg = SlaveConfig::unconfigured(ADDR);
            cfg.store = support;
            let mut s = LssSlave::new(cfg);
            assert_eq!(send(&mut s, Request::StoreConfiguration), None);
            let _ = send(&mut s, Request::SwitchModeGlobal(Mode::Configuration));
            let _ = send(&mut s, Request::ConfigureNodeId(7));
            assert_eq!(
                send(&mut s, Request::StoreConfiguration),
                Some(Response::StoreConfiguration(status))
            );
            let _ = s.poll_event();
            let stored = s.poll_event();
            assert_eq!(
                stored,
                (support == StoreSupport::Supported).then_some(SlaveEvent::StoreConfiguration {
                    node_id: 7,
                    bit_timing: BitRate::Kbit500.into()
                })
            );
        }
    }
}
