//! One line of CiA vocabulary for any frame on a CANopen bus: what `canopen monitor`, the demo
//! and logs print.
//!
//! Each wire type of the protocol crates implements `Display` (the SDO messages of CiA 301
//! §7.2.4.3, NMT, heartbeat and node guarding, EMCY, SYNC, TIME, the LSS requests and responses
//! of CiA 305); [`describe`] picks the decoder by COB-ID (CiA 301 predefined connection set,
//! §7.3.5) and adds what a [`BusDictionary`] knows: object names for SDO requests and the
//! mapped values of PDOs, read from each node's dictionary (its mapping parameters 0x1600..,
//! 0x1A00.. and COB-IDs 0x1400.., 0x1800..).
//!
//! PDOs decode the same way in classic frames and in CAN FD frames (CANopen FD, up to 64 data
//! bytes): one mapping under the CAN FD limits ([`FdMapping`], a classic mapping is one) read
//! from the data bytes, the padding of an FD frame after the mapped bytes ignored
//! ([`BusDictionary::decode_pdo`], [`BusDictionary::decode_fd_pdo`], [`describe_fd`]). Other
//! CAN FD frames are shown as not decoded.
//!
//! A frame that does not decode still gets a line: the decoder's error beside its bytes.

use core::fmt;
use std::collections::HashMap;

use canola_frame::cob::{FunctionCode, LSS_MASTER_TO_SLAVE, LSS_SLAVE_TO_MASTER};
use canola_frame::{CanFrame, CanId, CobId, FdFrame, HexBytes, NodeId};
use canola_nmt::{Emcy, ErrorControlMessage, NmtCommand, SyncMessage, TimeOfDay};
use canola_od::{ObjectAddress, ObjectDictionary};
use canola_pdo::{CommParams, Direction, FdMapping, OdView, PackError};
use canola_sdo::{ClientRequest, Multiplexer, ServerResponse};

/// What [`describe`] knows about the nodes on a bus: their dictionaries (for object names) and
/// the PDOs those dictionaries configure (for decoded values).
#[derive(Debug, Default, Clone)]
pub struct BusDictionary {
    nodes: HashMap<NodeId, ObjectDictionary>,
    pdos: HashMap<u16, PdoLayout>,
}

/// A PDO decoded by [`BusDictionary::decode_pdo`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct DecodedPdo {
    /// `TPDO1 node 5`.
    pub label: String,
    /// The mapped objects' values, in PDO order.
    pub values: Vec<PdoValue>,
}

/// One mapped object's value in a [`DecodedPdo`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct PdoValue {
    /// The mapped object.
    pub address: ObjectAddress,
    /// Its name (`Object / Sub-object` for records and arrays).
    pub name: String,
    /// Its value as the mapping types it.
    pub value: canola_pdo::RawValue,
}

/// One configured PDO: its label (`TPDO1 node 5`), mapping (under the CAN FD limits, which
/// hold every classic mapping too) and the mapped objects' names.
#[derive(Debug, Clone)]
struct PdoLayout {
    label: String,
    mapping: FdMapping,
    names: Vec<String>,
}

impl PdoLayout {
    /// The PDO's values in `data`, classic or CAN FD alike: bytes after the mapping (an FD
    /// frame's padding) are ignored; data shorter than the mapping is an error.
    fn decode(&self, data: &[u8]) -> Result<DecodedPdo, PackError> {
        let values = canola_pdo::unpack_fd(&self.mapping, data)?;
        Ok(DecodedPdo {
            label: self.label.clone(),
            values: self
                .mapping
                .objects()
                .iter()
                .zip(values)
                .zip(&self.names)
                .map(|((object, value), name)| PdoValue {
                    address: ObjectAddress::new(object.entry.index(), object.entry.subindex()),
                    name: name.clone(),
                    value,
                })
                .collect(),
        })
    }
}

impl fmt::Display for DecodedPdo {
    /// `TPDO1 node 5: Name = value, Other name = value`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.label)?;
        for (i, v) in self.values.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{} = {}", v.name, v.value)?;
        }
        Ok(())
    }
}

/// The name of `index:sub` in `od` ([`ObjectDictionary::display_name`]).
pub(crate) fn object_name(od: &ObjectDictionary, index: u16, sub: u8) -> Option<String> {
    od.display_name(ObjectAddress::new(index, sub))
}

impl BusDictionary {
    /// Knows nothing: frames are described by their protocol alone.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds (or replaces) `node`'s dictionary, with the PDOs it configures: every TPDO and RPDO
    /// whose COB-ID is valid and 11-bit and whose mapping is not empty and fits a CAN FD PDO
    /// (at most 64 bytes; a mapping of more than 8 bytes decodes only from CAN FD frames).
    pub fn with_node(mut self, node: NodeId, od: ObjectDictionary) -> Self {
        self.add_node(node, od);
        self
    }

    /// [`with_node`](Self::with_node) in place.
    pub fn add_node(&mut self, node: NodeId, od: ObjectDictionary) {
        let view = OdView::new(&od, node.get());
        for (kind, direction) in [("TPDO", Direction::Transmit), ("RPDO", Direction::Receive)] {
            for n in 0..512u16 {
                let (Ok(comm), Ok(mapping)) = (
                    CommParams::read_from(&view, direction.comm_index(n)),
                    FdMapping::read_from(&view, direction, direction.mapping_index(n)),
                ) else {
                    continue;
                };
                let Ok(CanId::Standard(id)) = comm.cob_id.can_id() else {
                    continue;
                };
                if !comm.cob_id.is_valid() || mapping.is_empty() {
                    continue;
                }
                let names = mapping
                    .objects()
                    .iter()
                    .map(|o| {
                        let (i, s) = (o.entry.index(), o.entry.subindex());
                        object_name(&od, i, s).unwrap_or_else(|| format!("{i:#06x}:{s:02x}"))
                    })
                    .collect();
                self.pdos.insert(
                    id.as_raw(),
                    PdoLayout {
                        label: format!("{kind}{} node {node}", n + 1),
                        mapping,
                        names,
                    },
                );
            }
        }
        self.nodes.insert(node, od);
    }

    /// The values of a PDO that one of the dictionaries configures: its label (`TPDO1 node
    /// 5`) and each mapped object (dummy entries included) with its address, name and value,
    /// in PDO order. `None` for any other frame (and remote frames); `Some(Err(_))` when the
    /// data is shorter than the mapping.
    pub fn decode_pdo(&self, frame: &CanFrame) -> Option<Result<DecodedPdo, PackError>> {
        if frame.is_remote() {
            return None;
        }
        Some(self.pdo(frame.cob_id()?)?.decode(frame.data()))
    }

    /// [`decode_pdo`](Self::decode_pdo) for a CAN FD frame (a CANopen FD PDO of up to 64
    /// bytes): the same decoding, the padding after the mapped bytes ignored.
    pub fn decode_fd_pdo(&self, frame: &FdFrame) -> Option<Result<DecodedPdo, PackError>> {
        Some(self.pdo(frame.cob_id()?)?.decode(frame.data()))
    }

    /// The PDO configured on 11-bit identifier `cob_id`.
    fn pdo(&self, cob_id: u16) -> Option<&PdoLayout> {
        self.pdos.get(&cob_id)
    }

    /// The dictionary of `node`, if known.
    pub fn dictionary(&self, node: NodeId) -> Option<&ObjectDictionary> {
        self.nodes.get(&node)
    }
}

/// A frame described for people: `Display` gives the frame (identifier, length, bytes) and
/// what it is, e.g. `605   [8]  40 18 10 01 00 00 00 00   node 5: SDO initiate upload request
/// 0x1018:01 (Identity object / Vendor-ID)`. [`what`](Self::what) gives the second part alone.
#[derive(Debug, Clone, Copy)]
pub struct Description<'a> {
    frame: &'a CanFrame,
    dictionary: &'a BusDictionary,
}

/// Describes `frame` with what `dictionary` knows about the nodes on the bus.
pub fn describe<'a>(frame: &'a CanFrame, dictionary: &'a BusDictionary) -> Description<'a> {
    Description { frame, dictionary }
}

impl<'a> Description<'a> {
    /// What the frame is, without the frame itself.
    pub fn what(&self) -> What<'a> {
        What(*self)
    }
}

impl fmt::Display for Description<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let frame = self.frame.to_string();
        write!(f, "{frame:<28} {}", self.what())
    }
}

/// Describes a stream of frames as [`describe`] does, and also follows each node's SDO block
/// transfers (CiA 301 §7.2.4.3.9..14), so a block segment reads as one. A block segment and a
/// segment of a segmented transfer share their first byte's layout; only the transfer's state
/// tells them apart, which a single frame does not carry.
#[derive(Debug, Default, Clone)]
pub struct Monitor {
    dictionary: BusDictionary,
    blocks: HashMap<NodeId, Block>,
}

/// A block transfer in progress on a node's default SDO channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Block {
    /// Server → client segments; `ended` once the segment with c = 1 went by (the next server
    /// frame is the end message).
    Upload { ended: bool },
    /// Client → server segments, likewise.
    Download { ended: bool },
}

impl Monitor {
    /// A monitor that names objects and decodes PDOs with `dictionary`.
    pub fn new(dictionary: BusDictionary) -> Self {
        Self {
            dictionary,
            blocks: HashMap::new(),
        }
    }

    /// The line for the next frame on the bus: the frame, then [`what`](Self::what) it is
    /// (as [`Description`] shows it).
    pub fn describe(&mut self, frame: &CanFrame) -> String {
        let shown = frame.to_string();
        format!("{shown:<28} {}", self.what(frame))
    }

    /// What the next frame on the bus is, without the frame itself.
    pub fn what(&mut self, frame: &CanFrame) -> String {
        if let Some(text) = self.block_segment(frame) {
            return text;
        }
        self.follow(frame);
        describe(frame, &self.dictionary).what().to_string()
    }

    /// Follows the next frame on the bus as [`what`](Self::what) does, without describing it:
    /// `true` when it is a segment of a block transfer in progress (for an analysis that reads
    /// the other frames with the protocol decoders itself).
    pub fn observe(&mut self, frame: &CanFrame) -> bool {
        if self.next_segment(frame).is_some() {
            return true;
        }
        self.follow(frame);
        false
    }

    /// What a CAN FD frame is: a PDO the dictionary maps, decoded as [`what`](Self::what)
    /// decodes a classic one ([`describe_fd`]).
    pub fn what_fd(&mut self, frame: &FdFrame) -> String {
        describe_fd(frame, &self.dictionary).to_string()
    }

    /// Whether `frame`, the next frame on the bus, is a segment of a block transfer in progress
    /// (as [`what`](Self::what) will read it). Asks without following the frame.
    pub fn is_block_segment(&self, frame: &CanFrame) -> bool {
        self.segment_of(frame).is_some()
    }

    /// The node and segment when `frame` is a segment of a block transfer in progress: a frame
    /// of the side that sends segments, whose sequence number is not 0 (byte 0 `0x80` there is
    /// an abort transfer message, CiA 301 §7.2.4.3.17).
    fn segment_of(&self, frame: &CanFrame) -> Option<(NodeId, canola_sdo::BlockSegment)> {
        if frame.is_remote() {
            return None;
        }
        let cob = CobId::classify(frame.cob_id()?)?;
        let node = cob.node?;
        match (cob.function, self.blocks.get(&node)?) {
            (FunctionCode::SdoTx, Block::Upload { ended: false })
            | (FunctionCode::SdoRx, Block::Download { ended: false }) => {}
            _ => return None,
        }
        let segment = canola_sdo::BlockSegment::parse(frame.data()).ok()?;
        (segment.seqno != 0).then_some((node, segment))
    }

    /// The text of `frame` when it is a segment of a block transfer in progress.
    fn block_segment(&mut self, frame: &CanFrame) -> Option<String> {
        let (node, segment) = self.next_segment(frame)?;
        Some(format!("node {node}: {segment}"))
    }

    /// The node and segment when `frame` is a segment of a block transfer in progress, the
    /// transfer's state moved on by it.
    fn next_segment(&mut self, frame: &CanFrame) -> Option<(NodeId, canola_sdo::BlockSegment)> {
        let (node, segment) = self.segment_of(frame)?;
        let block = self.blocks.get_mut(&node)?;
        if segment.last {
            *block = match block {
                Block::Upload { .. } => Block::Upload { ended: true },
                Block::Download { .. } => Block::Download { ended: true },
            };
        }
        Some((node, segment))
    }

    /// Starts or ends a node's block transfer by the messages that do.
    fn follow(&mut self, frame: &CanFrame) {
        let Some(cob) = frame.cob_id().and_then(CobId::classify) else {
            return;
        };
        let Some(node) = cob.node else { return };
        let data = frame.data();
        match cob.function {
            FunctionCode::SdoRx => match ClientRequest::parse(data) {
                Ok(ClientRequest::BlockUploadStart) => {
                    self.blocks.insert(node, Block::Upload { ended: false });
                }
                // A log may start inside a transfer: an acknowledgement says the server sends
                // the next sub-block (unless the last segment already went by).
                Ok(ClientRequest::BlockUploadAck { .. }) => {
                    let ended = self.blocks.get(&node) == Some(&Block::Upload { ended: true });
                    self.blocks.insert(node, Block::Upload { ended });
                }
                Ok(ClientRequest::BlockDownloadEnd { .. } | ClientRequest::Abort { .. }) => {
                    self.blocks.remove(&node);
                }
                _ => {}
            },
            FunctionCode::SdoTx => match ServerResponse::parse(data) {
                Ok(ServerResponse::BlockDownloadInitiate { .. }) => {
                    self.blocks.insert(node, Block::Download { ended: false });
                }
                Ok(ServerResponse::BlockDownloadAck { .. }) => {
                    let ended = self.blocks.get(&node) == Some(&Block::Download { ended: true });
                    self.blocks.insert(node, Block::Download { ended });
                }
                Ok(ServerResponse::BlockUploadEnd { .. } | ServerResponse::Abort { .. }) => {
                    self.blocks.remove(&node);
                }
                _ => {}
            },
            _ => {}
        }
    }
}

/// The protocol part of a [`Description`].
#[derive(Debug, Clone, Copy)]
pub struct What<'a>(Description<'a>);

/// `(Object / Sub-object)` after an SDO message about `mux`, when the node's dictionary names it.
fn name_suffix(
    f: &mut fmt::Formatter<'_>,
    dictionary: &BusDictionary,
    node: NodeId,
    mux: Option<Multiplexer>,
) -> fmt::Result {
    let name = mux.and_then(|m| {
        dictionary
            .dictionary(node)
            .and_then(|od| object_name(od, m.index, m.subindex))
    });
    match name {
        Some(n) => write!(f, " ({n})"),
        None => Ok(()),
    }
}

impl fmt::Display for What<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Description { frame, dictionary } = self.0;
        let data = frame.data();
        let Some(raw) = frame.cob_id() else {
            return write!(f, "extended identifier {}", HexBytes(data));
        };
        if !frame.is_remote()
            && let Some(pdo) = dictionary.pdo(raw)
        {
            return describe_pdo(f, pdo, data);
        }
        match raw {
            LSS_MASTER_TO_SLAVE => {
                return match canola_lss::Request::from_frame(frame) {
                    Ok(r) => write!(f, "{r}"),
                    Err(e) => write!(f, "LSS request, undecodable ({e}): {}", HexBytes(data)),
                };
            }
            LSS_SLAVE_TO_MASTER => {
                return match canola_lss::Response::from_frame(frame) {
                    Ok(r) => write!(f, "{r}"),
                    Err(e) => write!(f, "LSS response, undecodable ({e}): {}", HexBytes(data)),
                };
            }
            _ => {}
        }
        let Some(cob) = CobId::classify(raw) else {
            return write!(f, "{}", HexBytes(data));
        };
        match (cob.function, cob.node) {
            (FunctionCode::Nmt, _) => match NmtCommand::from_frame(frame) {
                Ok(cmd) => write!(f, "{cmd}"),
                Err(e) => write!(f, "NMT, undecodable ({e}): {}", HexBytes(data)),
            },
            (FunctionCode::Sync, _) => match SyncMessage::from_frame(frame, raw) {
                Ok(m) => write!(f, "{m}"),
                Err(e) => write!(f, "SYNC, undecodable ({e}): {}", HexBytes(data)),
            },
            (FunctionCode::Time, _) => match TimeOfDay::from_frame(frame, raw) {
                Ok(t) => write!(f, "{t}"),
                Err(e) => write!(f, "TIME, undecodable ({e}): {}", HexBytes(data)),
            },
            (FunctionCode::Emcy, Some(n)) => match Emcy::parse(data) {
                Ok(e) => write!(f, "node {n}: {e}"),
                Err(e) => write!(f, "node {n}: EMCY, undecodable ({e}): {}", HexBytes(data)),
            },
            (FunctionCode::Tpdo(p), Some(n)) if frame.is_remote() => write!(
                f,
                "TPDO{} node {n}: remote transmission request ({} bytes asked)",
                p.get(),
                frame.dlc()
            ),
            (FunctionCode::Rpdo(p), Some(n)) if frame.is_remote() => write!(
                f,
                "RPDO{} node {n}: remote transmission request ({} bytes asked)",
                p.get(),
                frame.dlc()
            ),
            (FunctionCode::Tpdo(p), Some(n)) => {
                write!(f, "TPDO{} node {n}: {}", p.get(), HexBytes(data))
            }
            (FunctionCode::Rpdo(p), Some(n)) => {
                write!(f, "RPDO{} node {n}: {}", p.get(), HexBytes(data))
            }
            (FunctionCode::SdoRx, Some(n)) => match ClientRequest::parse(data) {
                Ok(r) => {
                    write!(f, "node {n}: {r}")?;
                    name_suffix(f, dictionary, n, request_mux(&r))
                }
                Err(e) => write!(
                    f,
                    "node {n}: SDO request, undecodable ({e}): {}",
                    HexBytes(data)
                ),
            },
            (FunctionCode::SdoTx, Some(n)) => match ServerResponse::parse(data) {
                Ok(r) => {
                    write!(f, "node {n}: {r}")?;
                    name_suffix(f, dictionary, n, response_mux(&r))
                }
                Err(e) => write!(
                    f,
                    "node {n}: SDO response, undecodable ({e}): {}",
                    HexBytes(data)
                ),
            },
            (FunctionCode::NmtErrorControl, Some(_)) => {
                match ErrorControlMessage::from_frame(frame) {
                    Ok(m) => write!(f, "{m}"),
                    Err(e) => write!(f, "error control, undecodable ({e}): {}", HexBytes(data)),
                }
            }
            _ => write!(f, "{}", HexBytes(data)),
        }
    }
}

/// The object an SDO request is about, for the messages that carry it.
fn request_mux(r: &ClientRequest) -> Option<Multiplexer> {
    match *r {
        ClientRequest::InitiateDownload { mux, .. }
        | ClientRequest::InitiateUpload { mux }
        | ClientRequest::Abort { mux, .. }
        | ClientRequest::BlockDownloadInitiate { mux, .. }
        | ClientRequest::BlockUploadInitiate { mux, .. } => Some(mux),
        _ => None,
    }
}

/// The object an SDO response is about, for the messages that carry it.
fn response_mux(r: &ServerResponse) -> Option<Multiplexer> {
    match *r {
        ServerResponse::InitiateUpload { mux, .. }
        | ServerResponse::InitiateDownload { mux }
        | ServerResponse::Abort { mux, .. }
        | ServerResponse::BlockDownloadInitiate { mux, .. }
        | ServerResponse::BlockUploadInitiate { mux, .. } => Some(mux),
        _ => None,
    }
}

/// A configured PDO's line, classic or CAN FD: its decoded values, or its bytes and why they
/// do not decode.
fn describe_pdo(f: &mut fmt::Formatter<'_>, pdo: &PdoLayout, data: &[u8]) -> fmt::Result {
    match pdo.decode(data) {
        Ok(decoded) => write!(f, "{decoded}"),
        Err(e) => write!(
            f,
            "{}: {} (does not fit its mapping: {e})",
            pdo.label,
            HexBytes(data)
        ),
    }
}

/// What a CAN FD frame is, with what `dictionary` knows: a PDO it maps, decoded as in a classic
/// frame (`TPDO1 node 5: Inputs / Input 1 = 7, ...`); any other FD frame is `CAN FD frame (not
/// decoded)`. `Display` gives that text (without the frame itself).
#[derive(Debug, Clone, Copy)]
pub struct FdDescription<'a> {
    frame: &'a FdFrame,
    dictionary: &'a BusDictionary,
}

/// Describes a CAN FD frame with what `dictionary` knows (see [`FdDescription`]).
pub fn describe_fd<'a>(frame: &'a FdFrame, dictionary: &'a BusDictionary) -> FdDescription<'a> {
    FdDescription { frame, dictionary }
}

impl fmt::Display for FdDescription<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.frame.cob_id().and_then(|id| self.dictionary.pdo(id)) {
            Some(pdo) => describe_pdo(f, pdo, self.frame.data()),
            None => f.write_str("CAN FD frame (not decoded)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_monitor_tells_block_segments_from_segmented_ones() {
        let mut m = Monitor::new(BusDictionary::new());
        let f = |id, d: &[u8]| frame(id, d);
        // The same bytes are an upload segment outside a block transfer...
        let seg = [0x01, 1, 2, 3, 4, 5, 6, 7];
        assert!(
            m.describe(&f(0x585, &seg))
                .contains("SDO upload segment response")
        );
        // ...and block segment 1 inside one (after the client's start block upload).
        m.describe(&f(0x605, &[0xA3, 0, 0, 0, 0, 0, 0, 0]));
        assert!(m.describe(&f(0x585, &seg)).contains("SDO block segment 1"));
        let last = [0x82, 8, 9, 10, 11, 12, 13, 14];
        assert!(
            m.describe(&f(0x585, &last))
                .contains("SDO block segment 2, 08 09 0a 0b 0c 0d 0e, last")
        );
        m.describe(&f(0x605, &[0xA2, 2, 127, 0, 0, 0, 0, 0]));
        // After the last segment the server's end message: 0xC1 | unused << 2.
        let end = m.describe(&f(0x585, &[0xC5, 0x34, 0x12, 0, 0, 0, 0, 0]));
        assert!(end.contains("SDO end block upload"), "{end}");
        assert!(
            m.describe(&f(0x585, &seg))
                .contains("SDO upload segment response")
        );
    }

    #[test]
    fn a_log_that_starts_inside_a_block_transfer_reads_its_segments() {
        let mut m = Monitor::new(BusDictionary::new());
        let f = |id, d: &[u8]| frame(id, d);
        // Block download in progress, its initiate not seen: the server's acknowledgement
        // (ackseq 127, blksize 127) says the client sends block segments next.
        let ack = m.describe(&f(0x584, &[0xA2, 0x7F, 0x7F, 0, 0, 0, 0, 0]));
        assert!(ack.contains("block"), "{ack}");
        let seg = m.describe(&f(0x604, &[0x81, 1, 2, 3, 4, 5, 6, 7]));
        assert!(
            seg.contains("SDO block segment 1") && seg.ends_with("last"),
            "{seg}"
        );
        // The end message after the last segment is not read as a segment.
        let end = m.describe(&f(0x604, &[0xC5, 0, 0, 0, 0, 0, 0, 0]));
        assert!(!end.contains("block segment"), "{end}");
        // Block upload in progress: the client's acknowledgement starts the next sub-block.
        m.describe(&f(0x606, &[0xA2, 127, 127, 0, 0, 0, 0, 0]));
        let up = m.describe(&f(0x586, &[0x01, 1, 2, 3, 4, 5, 6, 7]));
        assert!(up.contains("SDO block segment 1"), "{up}");
        // An abort from the server inside it is an abort (a segment's seqno is never 0),
        // and ends the transfer.
        let abort = m.describe(&f(0x586, &[0x80, 0x00, 0x60, 0x01, 0, 0, 2, 6]));
        assert!(abort.contains("SDO abort transfer 0x6000:01"), "{abort}");
        let after = m.describe(&f(0x586, &[0x01, 1, 2, 3, 4, 5, 6, 7]));
        assert!(after.contains("SDO upload segment response"), "{after}");
    }

    #[test]
    fn a_remote_request_for_a_pdo_says_so() {
        let none = BusDictionary::new();
        let rtr = CanFrame::remote(CanId::standard(0x181).unwrap(), 0).unwrap();
        assert_eq!(
            describe(&rtr, &none).what().to_string(),
            "TPDO1 node 1: remote transmission request (0 bytes asked)"
        );
        let d = burkert(5);
        let rtr = CanFrame::remote(CanId::standard(0x185).unwrap(), 8).unwrap();
        assert_eq!(
            describe(&rtr, &d).what().to_string(),
            "TPDO1 node 5: remote transmission request (8 bytes asked)"
        );
    }

    fn burkert(node: u8) -> BusDictionary {
        let eds = include_bytes!("../../../eds/burkert-generic.eds");
        BusDictionary::new().with_node(
            NodeId::new(node).unwrap(),
            canola_od::parse(eds).unwrap().od,
        )
    }

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new(CanId::standard(id).unwrap(), data).unwrap()
    }

    fn what(d: &BusDictionary, id: u16, data: &[u8]) -> String {
        describe(&frame(id, data), d).what().to_string()
    }

    #[test]
    fn pdos_decode_through_the_dictionary_mapping() {
        let d = burkert(5);
        // TPDO1 of node 5 (0x185) maps sensor values 1 and 2, both REAL32.
        let mut data = [0u8; 8];
        data[..4].copy_from_slice(&1.5f32.to_le_bytes());
        data[4..].copy_from_slice(&(-2.25f32).to_le_bytes());
        assert_eq!(
            what(&d, 0x185, &data),
            "TPDO1 node 5: Sensor Value 1 / Value = 1.5, Sensor Value 2 / Value = -2.25"
        );
        // TPDO3 (0x385) carries the NE 107 status byte.
        assert_eq!(
            what(&d, 0x385, &[2]),
            "TPDO3 node 5: Device Status Object / Device Status NamurNe107 = 2"
        );
        assert!(what(&d, 0x205, &data).starts_with("RPDO1 node 5: Control Value 1 / Value = 1.5"));
        // A frame too short for its mapping is reported, not decoded.
        assert!(what(&d, 0x185, &[1, 2]).contains("does not fit its mapping"));
        // A node without a dictionary: the PDO's bytes.
        assert_eq!(what(&d, 0x186, &[1]), "TPDO1 node 6: 01");
    }

    /// The CANopen FD test device of tests/vcan as node 7: TPDO1 (0x187) maps 64 bytes,
    /// fourteen UNSIGNED32 of 0x2100, a REAL32, an UNSIGNED16 and an INTEGER16.
    fn fd_device() -> BusDictionary {
        let eds = include_bytes!("../../../tests/vcan/fd-device.eds");
        BusDictionary::new().with_node(NodeId::new(7).unwrap(), canola_od::parse(eds).unwrap().od)
    }

    fn fd_frame(id: u16, data: &[u8]) -> FdFrame {
        FdFrame::new_padded(CanId::standard(id).unwrap(), data).unwrap()
    }

    /// TPDO1 data of the FD test device: Value n = n except Value 5, 21.5 °C, status 1,
    /// offset -5.
    fn sixty_four_bytes(value5: u32) -> Vec<u8> {
        let mut data: Vec<u8> = (1..=14u32)
            .flat_map(|n| if n == 5 { value5 } else { n }.to_le_bytes())
            .collect();
        data.extend(21.5f32.to_le_bytes());
        data.extend(1u16.to_le_bytes());
        data.extend((-5i16).to_le_bytes());
        data
    }

    #[test]
    fn a_64_byte_fd_pdo_decodes_by_name() {
        let d = fd_device();
        let data = sixty_four_bytes(0xDEAD_BEEF);
        assert_eq!(data.len(), 64);
        let frame = fd_frame(0x187, &data);
        let pdo = d.decode_fd_pdo(&frame).expect("a PDO").expect("fits");
        assert_eq!(pdo.label, "TPDO1 node 7");
        assert_eq!(pdo.values.len(), 17);
        let v5 = &pdo.values[4];
        assert_eq!(v5.address, ObjectAddress::new(0x2100, 5));
        assert_eq!(v5.name, "Measured values / Value 5");
        assert_eq!(v5.value, canola_pdo::RawValue::Unsigned(0xDEAD_BEEF));
        let last: Vec<_> = pdo.values[14..]
            .iter()
            .map(|v| (v.name.as_str(), v.value))
            .collect();
        assert_eq!(
            last,
            [
                ("Temperature", canola_pdo::RawValue::Real32(21.5)),
                ("Status word", canola_pdo::RawValue::Unsigned(1)),
                ("Offset", canola_pdo::RawValue::Signed(-5)),
            ]
        );
        // The text is the decoded PDO's, as for classic PDOs.
        let text = describe_fd(&frame, &d).to_string();
        assert_eq!(text, pdo.to_string());
        assert!(
            text.starts_with("TPDO1 node 7: Measured values / Value 1 = 1, ")
                && text.contains("Value 5 = 3735928559, ")
                && text.ends_with("Temperature = 21.5, Status word = 1, Offset = -5"),
            "{text}"
        );
        assert_eq!(Monitor::new(d.clone()).what_fd(&frame), text);
    }

    #[test]
    fn fd_and_classic_frames_decode_through_one_path() {
        // Burkert TPDO1 (8 bytes) in a classic frame and in an FD frame padded to 12 bytes:
        // the same values, the padding ignored.
        let d = burkert(5);
        let mut data = [0u8; 10];
        data[..4].copy_from_slice(&1.5f32.to_le_bytes());
        data[4..8].copy_from_slice(&(-2.25f32).to_le_bytes());
        let fd = fd_frame(0x185, &data);
        assert_eq!(fd.data().len(), 12);
        let classic = d.decode_pdo(&frame(0x185, &data[..8]));
        assert_eq!(d.decode_fd_pdo(&fd), classic);
        assert!(classic.is_some_and(|r| r.is_ok()));
        assert_eq!(
            describe_fd(&fd, &d).to_string(),
            what(&d, 0x185, &data[..8])
        );
        // The 64-byte mapping does not fit a classic frame, nor an FD frame of 32 bytes.
        let fdd = fd_device();
        let data = sixty_four_bytes(9);
        assert!(matches!(
            fdd.decode_pdo(&frame(0x187, &data[..8])),
            Some(Err(PackError::TooShort {
                needed: 64,
                actual: 8
            }))
        ));
        assert!(what(&fdd, 0x187, &data[..8]).contains("does not fit its mapping"));
        let short = fd_frame(0x187, &data[..32]);
        assert!(matches!(
            fdd.decode_fd_pdo(&short),
            Some(Err(PackError::TooShort { .. }))
        ));
        assert!(
            describe_fd(&short, &fdd)
                .to_string()
                .starts_with("TPDO1 node 7: 01 00 00 00")
        );
        // An FD frame that is no mapped PDO (a USDO request, another node's TPDO1, a 29-bit
        // identifier) is shown as not decoded.
        for f in [
            fd_frame(0x607, &[1, 2, 3]),
            fd_frame(0x188, &data),
            FdFrame::new(CanId::extended(0x187).unwrap(), &data).unwrap(),
        ] {
            assert_eq!(fdd.decode_fd_pdo(&f), None);
            assert_eq!(
                describe_fd(&f, &fdd).to_string(),
                "CAN FD frame (not decoded)"
            );
        }
    }

    #[test]
    fn every_protocol_in_cia_words() {
        let d = burkert(5);
        let none = BusDictionary::new();
        assert_eq!(
            what(&d, 0x605, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]),
            "node 5: SDO initiate upload request 0x1018:01 (Identity Object / Vendor ID)"
        );
        assert_eq!(
            what(&none, 0x605, &[0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]),
            "node 5: SDO initiate upload request 0x1018:01"
        );
        let abort = what(&none, 0x585, &[0x80, 0x00, 0x60, 0x01, 0, 0, 2, 6]);
        assert!(
            abort.starts_with("node 5: SDO abort transfer 0x6000:01: 0x06020000"),
            "{abort}"
        );
        assert_eq!(abort.matches("does not exist").count(), 1, "{abort}");
        assert_eq!(
            what(&none, 0x000, &[1, 0]),
            "NMT Start remote node, all nodes"
        );
        assert_eq!(what(&none, 0x080, &[]), "SYNC");
        assert_eq!(what(&none, 0x705, &[0]), "boot-up node 5");
        assert_eq!(what(&none, 0x705, &[5]), "heartbeat node 5 Operational");
        let emcy = what(&none, 0x085, &[0x00, 0x50, 0x01, 0, 0, 0, 0, 0]);
        assert!(emcy.starts_with("node 5: EMCY 0x5000"), "{emcy}");
        assert_eq!(emcy.matches("device hardware").count(), 1, "{emcy}");
        let lss = what(&none, 0x7E5, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
        assert!(lss.starts_with("LSS switch state global"), "{lss}");
        assert!(!lss.contains('{') && !emcy.contains('{') && !abort.contains("Some("));
        // Undecodable frames still get a line.
        assert!(what(&none, 0x000, &[1]).starts_with("NMT, undecodable"));
    }
}
