//! Emergency (CiA 301 §7.2.7): the EMCY message, the emergency error codes (CiA 301 table 21)
//! and the error register (0x1001), a consumer for the master and a producer with inhibit time
//! (0x1015) for devices.
//!
//! EMCY is eight data bytes on 0x080 + node-ID (0x1014): error code (UNSIGNED16, little-endian),
//! error register (UNSIGNED8), five manufacturer-specific bytes. Error code 0x0000 announces that
//! the errors are gone ("error reset or no error").

use core::fmt;

use canola_frame::cob::FunctionCode;
use canola_frame::{CanFrame, Duration, Instant, NodeId};
use heapless::Deque;

use crate::error::{CapacityError, DecodeError};
use crate::util::{data_frame, push_dropping_oldest};

/// An emergency error code. Open: every value is kept, known ones have a CiA 301 meaning.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EmcyCode(pub u16);

/// Exact codes first, then classes by their mask, most specific first.
const CODE_TABLE: &[(u16, u16, &str)] = &[
    (0x0000, 0xFFFF, "error reset or no error"),
    (0x8110, 0xFFFF, "CAN overrun (objects lost)"),
    (0x8120, 0xFFFF, "CAN in error passive mode"),
    (0x8130, 0xFFFF, "life guard error or heartbeat error"),
    (0x8140, 0xFFFF, "recovered from bus off"),
    (0x8150, 0xFFFF, "CAN-ID collision"),
    (0x8210, 0xFFFF, "PDO not processed due to length error"),
    (0x8220, 0xFFFF, "PDO length exceeded"),
    (
        0x8230,
        0xFFFF,
        "DAM MPDO not processed, destination object not available",
    ),
    (0x8240, 0xFFFF, "unexpected SYNC data length"),
    (0x8250, 0xFFFF, "RPDO timeout"),
    (0x2100, 0xFF00, "current, device input side"),
    (0x2200, 0xFF00, "current inside the device"),
    (0x2300, 0xFF00, "current, device output side"),
    (0x3100, 0xFF00, "mains voltage"),
    (0x3200, 0xFF00, "voltage inside the device"),
    (0x3300, 0xFF00, "output voltage"),
    (0x4100, 0xFF00, "ambient temperature"),
    (0x4200, 0xFF00, "device temperature"),
    (0x6100, 0xFF00, "internal software"),
    (0x6200, 0xFF00, "user software"),
    (0x6300, 0xFF00, "data set"),
    (0x8100, 0xFF00, "communication"),
    (0x8200, 0xFF00, "protocol error"),
    (0x1000, 0xFF00, "generic error"),
    (0x7000, 0xFF00, "additional modules"),
    (0x9000, 0xFF00, "external error"),
    (0xF000, 0xFF00, "additional functions"),
    (0xFF00, 0xFF00, "device specific"),
    (0x2000, 0xF000, "current"),
    (0x3000, 0xF000, "voltage"),
    (0x4000, 0xF000, "temperature"),
    (0x5000, 0xF000, "device hardware"),
    (0x6000, 0xF000, "device software"),
    (0x8000, 0xF000, "monitoring"),
];

impl EmcyCode {
    /// 0x0000 error reset or no error.
    pub const NO_ERROR: Self = Self(0x0000);
    /// 0x1000 generic error.
    pub const GENERIC: Self = Self(0x1000);
    /// 0x2000 current.
    pub const CURRENT: Self = Self(0x2000);
    /// 0x3000 voltage.
    pub const VOLTAGE: Self = Self(0x3000);
    /// 0x4000 temperature.
    pub const TEMPERATURE: Self = Self(0x4000);
    /// 0x5000 device hardware.
    pub const DEVICE_HARDWARE: Self = Self(0x5000);
    /// 0x6000 device software.
    pub const DEVICE_SOFTWARE: Self = Self(0x6000);
    /// 0x7000 additional modules.
    pub const ADDITIONAL_MODULES: Self = Self(0x7000);
    /// 0x8000 monitoring.
    pub const MONITORING: Self = Self(0x8000);
    /// 0x8100 communication.
    pub const COMMUNICATION: Self = Self(0x8100);
    /// 0x8110 CAN overrun (objects lost).
    pub const CAN_OVERRUN: Self = Self(0x8110);
    /// 0x8120 CAN in error passive mode.
    pub const ERROR_PASSIVE: Self = Self(0x8120);
    /// 0x8130 life guard error or heartbeat error.
    pub const LIFE_GUARD_OR_HEARTBEAT: Self = Self(0x8130);
    /// 0x8140 recovered from bus off.
    pub const RECOVERED_FROM_BUS_OFF: Self = Self(0x8140);
    /// 0x8150 CAN-ID collision.
    pub const COB_ID_COLLISION: Self = Self(0x8150);
    /// 0x8200 protocol error.
    pub const PROTOCOL_ERROR: Self = Self(0x8200);
    /// 0x8210 PDO not processed due to length error.
    pub const PDO_LENGTH_ERROR: Self = Self(0x8210);
    /// 0x8220 PDO length exceeded.
    pub const PDO_LENGTH_EXCEEDED: Self = Self(0x8220);
    /// 0x8230 DAM MPDO not processed, destination object not available.
    pub const DAM_MPDO_NOT_PROCESSED: Self = Self(0x8230);
    /// 0x8240 unexpected SYNC data length.
    pub const UNEXPECTED_SYNC_LENGTH: Self = Self(0x8240);
    /// 0x8250 RPDO timeout.
    pub const RPDO_TIMEOUT: Self = Self(0x8250);
    /// 0x9000 external error.
    pub const EXTERNAL: Self = Self(0x9000);
    /// 0xF000 additional functions.
    pub const ADDITIONAL_FUNCTIONS: Self = Self(0xF000);
    /// 0xFF00 device specific.
    pub const DEVICE_SPECIFIC: Self = Self(0xFF00);

    /// The CiA 301 meaning: the exact code's name if it has one, else its class's, else `None`.
    pub fn description(self) -> Option<&'static str> {
        CODE_TABLE
            .iter()
            .find(|(code, mask, _)| self.0 & mask == *code)
            .map(|(_, _, text)| *text)
    }

    /// Whether this is 0x0000, "error reset or no error".
    pub const fn is_reset(self) -> bool {
        self.0 == 0
    }
}

impl fmt::Display for EmcyCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.description() {
            Some(d) => write!(f, "{:#06x} ({d})", self.0),
            None => write!(f, "{:#06x}", self.0),
        }
    }
}

/// The error register (object 0x1001, byte 2 of EMCY). All eight bits are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ErrorRegister(pub u8);

impl ErrorRegister {
    /// Bit 0: generic error (set whenever any error is present).
    pub const GENERIC: Self = Self(1 << 0);
    /// Bit 1: current.
    pub const CURRENT: Self = Self(1 << 1);
    /// Bit 2: voltage.
    pub const VOLTAGE: Self = Self(1 << 2);
    /// Bit 3: temperature.
    pub const TEMPERATURE: Self = Self(1 << 3);
    /// Bit 4: communication error (overrun, error state).
    pub const COMMUNICATION: Self = Self(1 << 4);
    /// Bit 5: device profile specific.
    pub const DEVICE_PROFILE: Self = Self(1 << 5);
    /// Bit 7: manufacturer specific.
    pub const MANUFACTURER: Self = Self(1 << 7);
    /// No bit set.
    pub const EMPTY: Self = Self(0);

    /// The raw byte.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Whether every bit of `other` is set.
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether no bit is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Sets the bits of `other`.
    pub fn insert(&mut self, other: Self) {
        self.0 |= other.0;
    }

    /// Clears the bits of `other`.
    pub fn remove(&mut self, other: Self) {
        self.0 &= !other.0;
    }
}

impl core::ops::BitOr for ErrorRegister {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        Self(self.0 | rhs.0)
    }
}

impl fmt::Display for ErrorRegister {
    /// The names of the set bits, e.g. `generic|temperature`, or `none`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const NAMES: [&str; 8] = [
            "generic",
            "current",
            "voltage",
            "temperature",
            "communication",
            "device profile",
            "reserved bit 6",
            "manufacturer",
        ];
        if self.0 == 0 {
            return f.write_str("none");
        }
        let mut first = true;
        for (bit, name) in NAMES.iter().enumerate() {
            if self.0 & (1 << bit) != 0 {
                if !first {
                    f.write_str("|")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}

/// An emergency message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Emcy {
    /// Emergency error code.
    pub code: EmcyCode,
    /// The error register at the time of the emergency.
    pub register: ErrorRegister,
    /// Manufacturer-specific error field.
    pub manufacturer: [u8; 5],
}

impl Emcy {
    /// An emergency without manufacturer-specific data.
    pub const fn new(code: EmcyCode, register: ErrorRegister) -> Self {
        Self {
            code,
            register,
            manufacturer: [0; 5],
        }
    }

    /// Decodes the eight data bytes. Never panics.
    pub fn parse(data: &[u8]) -> Result<Self, DecodeError> {
        match *data {
            [c0, c1, reg, m0, m1, m2, m3, m4] => Ok(Self {
                code: EmcyCode(u16::from_le_bytes([c0, c1])),
                register: ErrorRegister(reg),
                manufacturer: [m0, m1, m2, m3, m4],
            }),
            _ => Err(DecodeError::Length {
                message: "EMCY",
                actual: data.len(),
            }),
        }
    }

    /// The eight data bytes.
    pub fn emit(&self) -> [u8; 8] {
        let [c0, c1] = self.code.0.to_le_bytes();
        let [m0, m1, m2, m3, m4] = self.manufacturer;
        [c0, c1, self.register.0, m0, m1, m2, m3, m4]
    }

    /// The frame on `cob_id` (normally [`emcy_cob_id`] of the producer).
    pub fn to_frame(&self, cob_id: u16) -> CanFrame {
        data_frame(cob_id, &self.emit())
    }
}

impl fmt::Display for Emcy {
    /// `EMCY 0x5000 (device hardware), error register 0x01 (generic)`, followed by
    /// `, manufacturer-specific 01 02 03 04 05` when those bytes are not all zero.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "EMCY {}, error register {:#04x} ({})",
            self.code, self.register.0, self.register
        )?;
        if self.manufacturer != [0; 5] {
            write!(
                f,
                ", manufacturer-specific {}",
                canola_frame::HexBytes(&self.manufacturer)
            )?;
        }
        Ok(())
    }
}

/// The default EMCY COB-ID of `node` (0x080 + node-ID).
pub const fn emcy_cob_id(node: NodeId) -> u16 {
    FunctionCode::Emcy.cob_id(node)
}

/// An emergency received by the master.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EmcyEvent {
    /// The producer.
    pub node: NodeId,
    /// When it was received.
    pub at: Instant,
    /// The message.
    pub emcy: Emcy,
}

impl fmt::Display for EmcyEvent {
    /// `node 5: EMCY 0x5000 (device hardware), error register 0x01 (generic)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "node {}: {}", self.node, self.emcy)
    }
}

/// Capacity of the consumer's event queue.
pub const EMCY_EVENT_CAPACITY: usize = 32;

/// Decodes emergencies for the master and queues them as events.
///
/// No timers. Call order: [`handle_frame`](Self::handle_frame) (or
/// [`handle_emcy`](Self::handle_emcy) for EMCY on configured COB-IDs) for each received frame,
/// then drain [`poll_event`](Self::poll_event). When the queue is full the oldest event is dropped
/// and counted in [`dropped_events`](Self::dropped_events).
#[derive(Debug, Clone, Default)]
pub struct EmcyConsumer {
    events: Deque<EmcyEvent, EMCY_EVENT_CAPACITY>,
    dropped: u32,
}

impl EmcyConsumer {
    /// An empty consumer.
    pub const fn new() -> Self {
        Self {
            events: Deque::new(),
            dropped: 0,
        }
    }

    /// Takes a frame on a default EMCY COB-ID (0x081..=0x0FF). Returns `Ok(false)` for any other
    /// frame, `Ok(true)` when an event was queued, an error for a malformed EMCY.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) -> Result<bool, DecodeError> {
        let node = match frame.cob_id() {
            Some(cob @ 0x081..=0x0FF) => NodeId::new((cob & 0x7F) as u8).ok(),
            _ => None,
        };
        let Some(node) = node else { return Ok(false) };
        if frame.is_remote() {
            return Err(DecodeError::UnexpectedRemote { message: "EMCY" });
        }
        self.handle_emcy(now, node, frame.data())?;
        Ok(true)
    }

    /// Takes the data bytes of an EMCY from `node`.
    pub fn handle_emcy(
        &mut self,
        now: Instant,
        node: NodeId,
        data: &[u8],
    ) -> Result<(), DecodeError> {
        let emcy = Emcy::parse(data)?;
        let ev = EmcyEvent {
            node,
            at: now,
            emcy,
        };
        if push_dropping_oldest(&mut self.events, ev) {
            self.dropped = self.dropped.saturating_add(1);
        }
        Ok(())
    }

    /// The next emergency.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<EmcyEvent> {
        self.events.pop_front()
    }

    /// How many events were dropped because the queue was full.
    pub const fn dropped_events(&self) -> u32 {
        self.dropped
    }
}

/// Capacity of the producer's queue of emergencies waiting for the inhibit time.
pub const EMCY_QUEUE_CAPACITY: usize = 8;

/// Sends a device's emergencies, spaced by the inhibit time (0x1015, multiples of 100 µs).
///
/// Call order: [`signal`](Self::signal) when an error occurs or is cleared; drain
/// [`poll_transmit`](Self::poll_transmit); when [`poll_timeout`](Self::poll_timeout) passes, call
/// [`handle_timeout`](Self::handle_timeout) and drain again. The application decides whether EMCY
/// is allowed in the current NMT state ([`DeviceState::allows`](crate::DeviceState::allows)).
#[derive(Debug, Clone)]
pub struct EmcyProducer {
    cob_id: u16,
    inhibit: Duration,
    last_sent: Option<Instant>,
    waiting: Deque<Emcy, EMCY_QUEUE_CAPACITY>,
    tx: Deque<Emcy, EMCY_QUEUE_CAPACITY>,
}

impl EmcyProducer {
    /// A producer on `cob_id` (0x1014, normally [`emcy_cob_id`]) with the inhibit time from
    /// 0x1015 in units of 100 µs (0 = none).
    pub const fn new(cob_id: u16, inhibit_100us: u16) -> Self {
        Self {
            cob_id,
            inhibit: Duration::from_micros(inhibit_100us as u64 * 100),
            last_sent: None,
            waiting: Deque::new(),
            tx: Deque::new(),
        }
    }

    /// Changes the inhibit time (an SDO write to 0x1015).
    pub fn set_inhibit_time(&mut self, inhibit_100us: u16) {
        self.inhibit = Duration::from_micros(u64::from(inhibit_100us) * 100);
    }

    /// Queues an emergency; it goes out now or as soon as the inhibit time allows. Fails when
    /// [`EMCY_QUEUE_CAPACITY`] emergencies are already waiting.
    pub fn signal(&mut self, now: Instant, emcy: Emcy) -> Result<(), CapacityError> {
        self.waiting.push_back(emcy).map_err(|_| CapacityError {
            capacity: EMCY_QUEUE_CAPACITY,
        })?;
        self.release(now);
        Ok(())
    }

    fn release(&mut self, now: Instant) {
        while !self.tx.is_full() {
            if let Some(last) = self.last_sent
                && now < last + self.inhibit
            {
                return;
            }
            let Some(emcy) = self.waiting.pop_front() else {
                return;
            };
            let _ = self.tx.push_back(emcy);
            self.last_sent = Some(now);
        }
    }

    /// Releases an emergency whose inhibit time has passed.
    pub fn handle_timeout(&mut self, now: Instant) {
        self.release(now);
    }

    /// The next emergency to send.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<Emcy> {
        self.tx.pop_front()
    }

    /// [`poll_transmit`](Self::poll_transmit) as a frame on the producer's COB-ID.
    #[must_use]
    pub fn poll_transmit_frame(&mut self) -> Option<CanFrame> {
        self.poll_transmit().map(|e| e.to_frame(self.cob_id))
    }

    /// When the next waiting emergency may go out.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        if self.waiting.is_empty() {
            return None;
        }
        Some(self.last_sent.map_or(Instant::ZERO, |t| t + self.inhibit))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;
    use proptest::prelude::*;

    fn node(n: u8) -> NodeId {
        NodeId::new(n).unwrap()
    }

    #[test]
    fn byte_vector() {
        // Heartbeat consumer error on node 5, error register communication|generic, manufacturer
        // bytes 01 02 03 04 05: 085#30811101 02030405.
        let e = Emcy {
            code: EmcyCode::LIFE_GUARD_OR_HEARTBEAT,
            register: ErrorRegister::GENERIC | ErrorRegister::COMMUNICATION,
            manufacturer: [1, 2, 3, 4, 5],
        };
        assert_eq!(e.emit(), [0x30, 0x81, 0x11, 1, 2, 3, 4, 5]);
        assert_eq!(
            e.to_frame(emcy_cob_id(node(5))).to_string(),
            "085#3081110102030405"
        );
        assert_eq!(Emcy::parse(&e.emit()), Ok(e));
        assert_eq!(
            e.to_string(),
            "EMCY 0x8130 (life guard error or heartbeat error), error register 0x11 \
             (generic|communication), manufacturer-specific 01 02 03 04 05"
        );
        assert_eq!(
            Emcy::new(EmcyCode::DEVICE_HARDWARE, ErrorRegister::GENERIC).to_string(),
            "EMCY 0x5000 (device hardware), error register 0x01 (generic)"
        );
        assert_eq!(
            Emcy::new(EmcyCode::NO_ERROR, ErrorRegister::EMPTY).to_string(),
            "EMCY 0x0000 (error reset or no error), error register 0x00 (none)"
        );
        assert_eq!(
            Emcy::new(EmcyCode(0xA001), ErrorRegister::EMPTY).to_string(),
            "EMCY 0xa001, error register 0x00 (none)"
        );
        assert!(Emcy::parse(&[0; 7]).is_err());
        assert!(Emcy::parse(&[]).is_err());
    }

    #[test]
    fn code_meanings() {
        let d = |c: u16| EmcyCode(c).description();
        assert_eq!(d(0x0000), Some("error reset or no error"));
        assert_eq!(d(0x0001), None);
        assert_eq!(d(0x1000), Some("generic error"));
        assert_eq!(d(0x2310), Some("current, device output side"));
        assert_eq!(d(0x2000), Some("current"));
        assert_eq!(d(0x3210), Some("voltage inside the device"));
        assert_eq!(d(0x4210), Some("device temperature"));
        assert_eq!(d(0x5530), Some("device hardware"));
        assert_eq!(d(0x6100), Some("internal software"));
        assert_eq!(d(0x7000), Some("additional modules"));
        assert_eq!(d(0x8110), Some("CAN overrun (objects lost)"));
        assert_eq!(d(0x8120), Some("CAN in error passive mode"));
        assert_eq!(d(0x8130), Some("life guard error or heartbeat error"));
        assert_eq!(d(0x8140), Some("recovered from bus off"));
        assert_eq!(d(0x8150), Some("CAN-ID collision"));
        assert_eq!(d(0x8111), Some("communication"));
        assert_eq!(d(0x8210), Some("PDO not processed due to length error"));
        assert_eq!(d(0x8220), Some("PDO length exceeded"));
        assert_eq!(
            d(0x8230),
            Some("DAM MPDO not processed, destination object not available")
        );
        assert_eq!(d(0x8240), Some("unexpected SYNC data length"));
        assert_eq!(d(0x8250), Some("RPDO timeout"));
        assert_eq!(d(0x8201), Some("protocol error"));
        assert_eq!(d(0x8300), Some("monitoring"));
        assert_eq!(d(0x9000), Some("external error"));
        assert_eq!(d(0xF001), Some("additional functions"));
        assert_eq!(d(0xFF42), Some("device specific"));
        assert_eq!(d(0xA000), None);
        assert_eq!(
            EmcyCode(0x8130).to_string(),
            "0x8130 (life guard error or heartbeat error)"
        );
        assert_eq!(EmcyCode(0xA001).to_string(), "0xa001");
    }

    #[test]
    fn error_register() {
        let mut r = ErrorRegister::GENERIC | ErrorRegister::TEMPERATURE;
        assert_eq!(r.bits(), 0x09);
        assert!(r.contains(ErrorRegister::TEMPERATURE));
        assert_eq!(r.to_string(), "generic|temperature");
        r.remove(ErrorRegister::TEMPERATURE);
        r.insert(ErrorRegister::MANUFACTURER);
        assert_eq!(r.bits(), 0x81);
        assert_eq!(ErrorRegister::EMPTY.to_string(), "none");
        assert_eq!(ErrorRegister(0x40).to_string(), "reserved bit 6");
    }

    #[test]
    fn consumer() {
        let mut c = EmcyConsumer::new();
        let t = Instant::from_millis(3);
        let f = Emcy::new(EmcyCode::GENERIC, ErrorRegister::GENERIC).to_frame(0x08A);
        assert_eq!(c.handle_frame(t, &f), Ok(true));
        let ev = c.poll_event().unwrap();
        assert_eq!(
            (ev.node, ev.at, ev.emcy.code),
            (node(10), t, EmcyCode::GENERIC)
        );
        assert_eq!(c.poll_event(), None);
        assert_eq!(
            c.handle_frame(t, &data_frame(0x080, &[])),
            Ok(false),
            "SYNC is not EMCY"
        );
        assert_eq!(c.handle_frame(t, &data_frame(0x100, &[0; 8])), Ok(false));
        assert!(c.handle_frame(t, &data_frame(0x081, &[0; 3])).is_err());
        for _ in 0..EMCY_EVENT_CAPACITY + 3 {
            c.handle_frame(t, &f).unwrap();
        }
        assert_eq!(c.dropped_events(), 3);
    }

    #[test]
    fn producer_inhibit_time() {
        // Inhibit 10 ms = 100 × 100 µs.
        let mut p = EmcyProducer::new(emcy_cob_id(node(2)), 100);
        let e1 = Emcy::new(
            EmcyCode::TEMPERATURE,
            ErrorRegister::GENERIC | ErrorRegister::TEMPERATURE,
        );
        let e0 = Emcy::new(EmcyCode::NO_ERROR, ErrorRegister::EMPTY);
        p.signal(Instant::from_millis(100), e1).unwrap();
        assert_eq!(
            p.poll_transmit_frame().map(|f| f.data()[0..2].to_vec()),
            Some(std::vec![0x00, 0x40])
        );
        assert_eq!(p.poll_timeout(), None);
        p.signal(Instant::from_millis(103), e0).unwrap();
        assert_eq!(p.poll_transmit_frame(), None, "inhibited");
        assert_eq!(p.poll_timeout(), Some(Instant::from_millis(110)));
        p.handle_timeout(Instant::from_millis(109));
        assert_eq!(p.poll_transmit_frame(), None);
        p.handle_timeout(Instant::from_millis(110));
        assert_eq!(
            p.poll_transmit_frame()
                .map(|f| Emcy::parse(f.data()).unwrap()),
            Some(e0)
        );
        for _ in 0..EMCY_QUEUE_CAPACITY {
            p.signal(Instant::from_millis(111), e1).unwrap();
        }
        assert!(p.signal(Instant::from_millis(111), e1).is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn round_trip(data in any::<[u8; 8]>()) {
            let e = Emcy::parse(&data).unwrap();
            prop_assert_eq!(e.emit(), data);
        }
    }
}
