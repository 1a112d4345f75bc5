//! Process data of the profile: sensor values (0x2500..=0x253F) received in a TPDO and control
//! values (0x2540..=0x257F) sent in an RPDO, with the mappings `BurkertNode` configures.

use super::*;

/// A sensor value received in a TPDO.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorReading {
    /// Sensor number: the object is `0x2500 + sensor`.
    pub sensor: u8,
    /// The value, typed by the object's data type (`Value::Real32` for the generic device).
    pub value: canola_od::Value,
}

/// A TPDO of the device configured by [`BurkertNode::map_sensor_values_to_tpdo`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SensorTpdo {
    pub(super) node: NodeId,
    pub(super) number: u8,
    pub(super) sensors: Vec<u8>,
    pub(super) mapping: Mapping,
    pub(super) cob_id: u32,
}

impl SensorTpdo {
    /// TPDO number 1..=4.
    pub fn number(&self) -> u8 {
        self.number
    }

    /// The sensors it carries, in PDO order.
    pub fn sensors(&self) -> &[u8] {
        &self.sensors
    }

    /// The mapping written to the device.
    pub fn mapping(&self) -> &Mapping {
        &self.mapping
    }

    /// The COB-ID written to comm sub 1.
    pub fn cob_id(&self) -> u32 {
        self.cob_id
    }

    /// Decodes the data of one PDO into typed sensor values.
    pub fn decode(&self, data: &[u8]) -> Result<Vec<SensorReading>, Error> {
        let tpdo = |problem| ValueProblem::Pdo {
            direction: Direction::Transmit,
            number: u16::from(self.number),
            problem,
        };
        let unpacked = canola_pdo::unpack(&self.mapping, data).map_err(|e| Error::Value {
            node: self.node,
            entry: ObjectAddress::new(0x1800 + u16::from(self.number) - 1, 1),
            problem: tpdo(PdoProblem::Pack(e)),
        })?;
        self.sensors
            .iter()
            .zip(unpacked.iter())
            .map(|(&sensor, (obj, raw))| {
                let value = raw.to_value(obj.data_type()).map_err(|e| Error::Value {
                    node: self.node,
                    entry: obj.addr(),
                    problem: tpdo(PdoProblem::Data(e)),
                })?;
                Ok(SensorReading { sensor, value })
            })
            .collect()
    }

    /// The sensor values in a network event, if it is this TPDO of this node.
    pub fn from_event(&self, event: &NetworkEvent) -> Option<Result<Vec<SensorReading>, Error>> {
        match event.pdo_data() {
            Some((node, number, data)) if node == self.node && number == self.number => {
                Some(self.decode(data))
            }
            _ => None,
        }
    }
}

/// An RPDO of the device configured by [`BurkertNode::map_control_values_to_rpdo`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ControlRpdo {
    pub(super) node: NodeId,
    pub(super) number: u8,
    pub(super) controls: Vec<u8>,
    pub(super) mapping: Mapping,
    pub(super) cob_id: u32,
}

impl ControlRpdo {
    /// RPDO number 1..=4.
    pub fn number(&self) -> u8 {
        self.number
    }

    /// The controls it carries, in PDO order.
    pub fn controls(&self) -> &[u8] {
        &self.controls
    }

    /// The mapping written to the device.
    pub fn mapping(&self) -> &Mapping {
        &self.mapping
    }

    /// The COB-ID written to comm sub 1.
    pub fn cob_id(&self) -> u32 {
        self.cob_id
    }

    /// The kinds of the values [`encode`](Self::encode) expects, in PDO order.
    pub fn kinds(&self) -> Vec<ValueKind> {
        self.mapping.objects().iter().map(|o| o.kind).collect()
    }

    /// Packs one value per control into the RPDO frame.
    pub fn encode(&self, values: &[canola_od::Value]) -> Result<CanFrame, Error> {
        let rpdo = |problem| ValueProblem::Pdo {
            direction: Direction::Receive,
            number: u16::from(self.number),
            problem,
        };
        let err = |problem| Error::Value {
            node: self.node,
            entry: ObjectAddress::new(0x1400 + u16::from(self.number) - 1, 1),
            problem: rpdo(problem),
        };
        let objects = self.mapping.objects();
        if values.len() != objects.len() {
            return Err(err(PdoProblem::Pack(canola_pdo::PackError::ValueCount {
                actual: values.len(),
                expected: objects.len(),
            })));
        }
        let raw = objects
            .iter()
            .zip(values)
            .map(|(o, v)| {
                PdoValue::from_value(v, o.kind).ok_or_else(|| Error::Value {
                    node: self.node,
                    entry: o.addr(),
                    problem: rpdo(PdoProblem::Field {
                        value: v.clone(),
                        kind: o.kind,
                    }),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut buf = [0u8; 8];
        let n = canola_pdo::pack(&self.mapping, &raw, &mut buf)
            .map_err(|e| err(PdoProblem::Pack(e)))?;
        let id = CanId::standard((self.cob_id & 0x7FF) as u16)
            .map_err(|_| err(PdoProblem::NotStandardCobId(self.cob_id)))?;
        CanFrame::new(id, &buf[..n]).map_err(|e| err(PdoProblem::Frame(e)))
    }
}
