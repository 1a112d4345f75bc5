//! RPDOs the master transmits (CiA 301 §7.2.2): how ([`Transmission`]: on change with an
//! inhibit time, cyclic, on SYNC) and the [`RpdoSender`] through which the application sets
//! mapped values, triggers and stops.

use canola_frame::{Duration, NodeId};
use canola_od::{ObjectAddress, ObjectDictionary};
use canola_pdo::TransmissionType;

use crate::error::{Error, MappedUnfit, ValueProblem};
use crate::network::request::NodeRef;
use crate::typed::{ObjectKey, WriteValue};

/// How the master transmits a node's RPDO: the transmission type, inhibit time and event timer
/// of the master's own transmit PDO (CiA 301 §7.2.2.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Transmission {
    /// 254/255: on change (and on the event timer); 0: on the SYNC after a change; 1..=240:
    /// every n-th SYNC.
    pub transmission_type: TransmissionType,
    /// Least time between two frames (event-driven types; a multiple of 100 µs).
    pub inhibit_time: Duration,
    /// A frame at least this often, changed or not (event-driven types; whole ms; zero = off).
    pub event_timer: Duration,
}

impl Transmission {
    /// On every change of a mapped value (type 255).
    pub const fn on_change() -> Self {
        Self {
            transmission_type: TransmissionType::EventProfile,
            inhibit_time: Duration::ZERO,
            event_timer: Duration::ZERO,
        }
    }

    /// Every `period` (type 255 with an event timer), and on change.
    pub fn cyclic(period: impl Into<Duration>) -> Self {
        Self::on_change().with_event_timer(period)
    }

    /// After every SYNC the master produces (type 1).
    pub const fn on_sync() -> Self {
        Self::every_nth_sync(1)
    }

    /// After every `n`-th SYNC (types 1..=240; `n` is clamped to that range).
    pub const fn every_nth_sync(n: u8) -> Self {
        let n = if n == 0 {
            1
        } else if n > 240 {
            240
        } else {
            n
        };
        Self {
            transmission_type: TransmissionType::SyncCyclic(n),
            inhibit_time: Duration::ZERO,
            event_timer: Duration::ZERO,
        }
    }

    /// After the SYNC that follows a change (type 0).
    pub const fn on_sync_after_change() -> Self {
        Self {
            transmission_type: TransmissionType::SyncAcyclic,
            inhibit_time: Duration::ZERO,
            event_timer: Duration::ZERO,
        }
    }

    /// The same with an inhibit time.
    pub fn with_inhibit_time(mut self, d: impl Into<Duration>) -> Self {
        self.inhibit_time = d.into();
        self
    }

    /// The same with an event timer.
    pub fn with_event_timer(mut self, d: impl Into<Duration>) -> Self {
        self.event_timer = d.into();
        self
    }
}

/// The application's side of an RPDO the master transmits ([`Rpdos::start`](crate::Rpdos::start)): set mapped
/// values, trigger, stop. Dropping it does not stop the transmission.
#[derive(Debug, Clone)]
pub struct RpdoSender {
    pub(super) node: NodeRef,
    pub(super) number: u16,
}

impl RpdoSender {
    /// The node.
    pub fn node(&self) -> NodeId {
        self.node.id
    }

    /// The RPDO number (1-based).
    pub fn number(&self) -> u16 {
        self.number
    }

    /// Sets one mapped value, by name or address, converted to the object's type in the node's
    /// dictionary (without one: an integer, float or bytes of the mapped length). An
    /// event-driven RPDO goes out now if the value changed (or when its inhibit time has
    /// passed); a synchronous one at its SYNC.
    pub fn set<'k>(
        &self,
        key: impl Into<ObjectKey<'k>>,
        value: impl Into<WriteValue>,
    ) -> Result<(), Error> {
        self.set_many([(key, value)])
    }

    /// Sets several mapped values at once: one frame carries them all.
    pub fn set_many<'k, K, V>(&self, values: impl IntoIterator<Item = (K, V)>) -> Result<(), Error>
    where
        K: Into<ObjectKey<'k>>,
        V: Into<WriteValue>,
    {
        self.node.net.shared().catch_up_on_runtime()?;
        self.stage(values)?;
        self.node.net.shared().send_queued_now()
    }

    /// Gives the engine the new values of [`set_many`](Self::set_many); the frames they cause
    /// are queued, not sent.
    fn stage<'k, K, V>(&self, values: impl IntoIterator<Item = (K, V)>) -> Result<(), Error>
    where
        K: Into<ObjectKey<'k>>,
        V: Into<WriteValue>,
    {
        let od = self.node.dictionary();
        let mut encoded = Vec::new();
        for (key, value) in values {
            let addr = self.node.sdo().resolve(key)?;
            // The mapping as the engine has it now (a saved RPDO may have changed it).
            let bits = match self
                .node
                .net
                .core()
                .rpdo_bits(self.node.id, self.number, addr)
            {
                None => return Err(self.stopped()),
                Some(Err(())) => {
                    return Err(Error::Value {
                        node: self.node.id,
                        entry: addr,
                        problem: crate::error::ValueProblem::NotMapped { rpdo: self.number },
                    });
                }
                Some(Ok(bits)) => bits,
            };
            let bytes = encode(od.as_deref(), addr, bits, value.into()).map_err(|problem| {
                Error::Value {
                    node: self.node.id,
                    entry: addr,
                    problem,
                }
            })?;
            encoded.push((addr, bytes));
        }
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        core.set_rpdo_values(self.node.id, &encoded);
        Ok(())
    }

    /// Sends the RPDO now (event-driven: after its inhibit time; type 0: at the next SYNC),
    /// changed or not.
    pub fn trigger(&self) -> Result<(), Error> {
        self.node.net.shared().catch_up_on_runtime()?;
        self.queue_trigger()?;
        self.node.net.shared().send_queued_now()
    }

    fn queue_trigger(&self) -> Result<(), Error> {
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        if core.trigger_rpdo(self.node.id, self.number) {
            Ok(())
        } else {
            Err(self.stopped())
        }
    }

    /// Stops transmitting the RPDO.
    pub fn stop(&self) -> Result<(), Error> {
        let now = self.node.net.now();
        let mut core = self.node.net.core();
        core.set_now(now);
        if !core.stop_rpdo(self.node.id, self.number) {
            return Err(self.stopped());
        }
        Ok(())
    }

    pub(super) fn stopped(&self) -> Error {
        Error::InvalidRequest(crate::error::Misuse::RpdoNotTransmitted {
            node: self.node.id,
            rpdo: self.number,
        })
    }
}

/// `value` as the little-endian bytes of a mapped object of `bits` bits.
pub(super) fn encode(
    od: Option<&ObjectDictionary>,
    addr: ObjectAddress,
    bits: u8,
    value: WriteValue,
) -> Result<Vec<u8>, ValueProblem> {
    let len = usize::from(bits).div_ceil(8);
    if let Some(od) = od
        && let Some(sub) = od.sub(addr.index, addr.sub_index)
    {
        let typed =
            crate::typed::convert(value, sub.data_type).map_err(|why| ValueProblem::Unfit {
                object: crate::typed::object_name(od, addr),
                data_type: sub.data_type,
                why,
            })?;
        let mut bytes = typed.to_le_bytes();
        if bytes.len() > len && bytes[len..].iter().any(|b| *b != 0) {
            return Err(ValueProblem::Mapped(MappedUnfit::Value {
                value: typed,
                bits,
            }));
        }
        bytes.resize(len, 0);
        return Ok(bytes);
    }
    // No type known: by the mapped length.
    let bytes = match value {
        WriteValue::Integer(v) => {
            let (lo, hi) = (-(1i128 << (bits - 1)), (1i128 << bits) - 1);
            if !(lo..=hi).contains(&v) {
                return Err(ValueProblem::Mapped(MappedUnfit::Integer {
                    value: v,
                    bits,
                }));
            }
            (v as u64).to_le_bytes()[..len.min(8)].to_vec()
        }
        WriteValue::Float(f) if bits == 32 => (f as f32).to_le_bytes().to_vec(),
        WriteValue::Float(f) if bits == 64 => f.to_le_bytes().to_vec(),
        WriteValue::Float(f) => {
            return Err(ValueProblem::Mapped(MappedUnfit::Float { value: f, bits }));
        }
        WriteValue::Bytes(b) if b.len() == len => b,
        WriteValue::Bytes(b) => {
            return Err(ValueProblem::Mapped(MappedUnfit::ByteCount {
                given: b.len(),
                mapped: len,
            }));
        }
        WriteValue::Value(v) => {
            let b = v.to_le_bytes();
            if b.len() != len {
                return Err(ValueProblem::Mapped(MappedUnfit::ByteCount {
                    given: b.len(),
                    mapped: len,
                }));
            }
            b
        }
        WriteValue::Text(s) => {
            return Err(ValueProblem::Mapped(MappedUnfit::NeedsDictionary(s)));
        }
    };
    Ok(bytes)
}
