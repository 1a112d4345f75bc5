//! The SDO transfers `canopen top` follows on each node's default channel, from the client's
//! requests and the server's responses alone: which object, which way, how many bytes so far,
//! and the aborts (logged with their CiA 301 meaning).

use canola::sdo::{ClientRequest, Initiate, Multiplexer, ServerResponse};
use canola::{Instant, NodeId};

use super::{LogKind, Model, object_name};

/// Which way an SDO transfer goes, and how.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SdoKind {
    Upload,
    Download,
    BlockUpload,
    BlockDownload,
}

impl SdoKind {
    pub(crate) fn label(self) -> &'static str {
        match self {
            Self::Upload => "read",
            Self::Download => "write",
            Self::BlockUpload => "block read",
            Self::BlockDownload => "block write",
        }
    }
}

/// An SDO transfer in flight on a node's default channel.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SdoTransfer {
    pub(crate) kind: SdoKind,
    pub(crate) index: u16,
    pub(crate) sub: u8,
    /// The object's name from the node's dictionary.
    pub(crate) name: Option<String>,
    /// Bytes moved so far.
    pub(crate) bytes: u64,
    /// The size the transfer announced.
    pub(crate) size: Option<u32>,
    pub(crate) started: Instant,
    pub(super) last: Instant,
    /// The last segment went by: the next answer ends the transfer.
    pub(super) ending: bool,
    /// Block transfer: the segments are streaming (they are not SDO commands).
    pub(super) streaming: bool,
}

impl Model {
    fn name_of(&self, node: NodeId, mux: Multiplexer) -> Option<String> {
        self.dictionary
            .dictionary(node)
            .and_then(|od| object_name(od, mux.index, mux.subindex))
    }

    fn start_sdo(&mut self, at: Instant, node: NodeId, kind: SdoKind, mux: Multiplexer) {
        let name = self.name_of(node, mux);
        self.sdo.insert(
            node,
            SdoTransfer {
                kind,
                index: mux.index,
                sub: mux.subindex,
                name,
                bytes: 0,
                size: None,
                started: at,
                last: at,
                ending: false,
                streaming: false,
            },
        );
    }

    fn sdo_abort(&mut self, at: Instant, node: NodeId, by: &str, code: canola::AbortCode) {
        let t = self.sdo.remove(&node);
        let what = t
            .map(|t| format!(" {} 0x{:04X}:{:02X}", t.kind.label(), t.index, t.sub))
            .unwrap_or_default();
        self.note(
            at,
            LogKind::Warning,
            format!(
                "node {node}: SDO{what} aborted by the {by}: 0x{:08X} {}",
                code.get(),
                code.description().unwrap_or("unknown abort code")
            ),
        );
    }

    pub(super) fn sdo_request(&mut self, at: Instant, node: NodeId, data: &[u8]) {
        // A block download's sub-block segments are not commands.
        if let Some(t) = self.sdo.get_mut(&node)
            && t.kind == SdoKind::BlockDownload
            && t.streaming
        {
            t.last = at;
            t.bytes += 7;
            if data.first().is_some_and(|b| b & 0x80 != 0) {
                t.streaming = false;
            }
            return;
        }
        let Ok(req) = ClientRequest::parse(data) else {
            return;
        };
        match req {
            ClientRequest::InitiateUpload { mux } => {
                self.start_sdo(at, node, SdoKind::Upload, mux);
            }
            ClientRequest::InitiateDownload { mux, data } => {
                self.start_sdo(at, node, SdoKind::Download, mux);
                if let Some(t) = self.sdo.get_mut(&node) {
                    match data {
                        Initiate::Expedited { size, .. } => {
                            t.bytes = u64::from(size.unwrap_or(4));
                            t.ending = true;
                        }
                        Initiate::Segmented { size } => t.size = size,
                    }
                }
            }
            ClientRequest::BlockUploadInitiate { mux, .. } => {
                self.start_sdo(at, node, SdoKind::BlockUpload, mux);
            }
            ClientRequest::BlockDownloadInitiate { mux, size, .. } => {
                self.start_sdo(at, node, SdoKind::BlockDownload, mux);
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.size = size;
                }
            }
            ClientRequest::Abort { code, .. } => self.sdo_abort(at, node, "client", code),
            ClientRequest::DownloadSegment(seg) => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.last = at;
                    t.bytes += u64::from(seg.len);
                    t.ending = seg.last;
                }
            }
            ClientRequest::BlockUploadStart => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.last = at;
                    t.streaming = true;
                }
            }
            ClientRequest::BlockUploadAck { .. } => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.last = at;
                    // The server goes on with the next sub-block, or ends.
                    t.streaming = !t.ending;
                }
            }
            ClientRequest::BlockDownloadEnd { .. } => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.last = at;
                    t.ending = true;
                }
            }
            _ => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.last = at;
                }
            }
        }
    }

    pub(super) fn sdo_response(&mut self, at: Instant, node: NodeId, data: &[u8]) {
        if let Some(t) = self.sdo.get_mut(&node)
            && t.kind == SdoKind::BlockUpload
            && t.streaming
        {
            t.last = at;
            t.bytes += 7;
            if data.first().is_some_and(|b| b & 0x80 != 0) {
                t.streaming = false;
                t.ending = true;
            }
            return;
        }
        let Ok(resp) = ServerResponse::parse(data) else {
            return;
        };
        let done = match resp {
            ServerResponse::InitiateUpload { data, mux } => match data {
                Initiate::Expedited { data, .. } => {
                    if mux.index == 0x1018 && matches!(mux.subindex, 1 | 2) {
                        let v = u32::from_le_bytes(data);
                        let row = self.node(node);
                        if mux.subindex == 1 {
                            row.identity.0 = Some(v);
                        } else {
                            row.identity.1 = Some(v);
                        }
                    }
                    true
                }
                Initiate::Segmented { size } => {
                    if let Some(t) = self.sdo.get_mut(&node) {
                        t.size = size;
                    }
                    false
                }
            },
            ServerResponse::UploadSegment(seg) => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.bytes += u64::from(seg.len);
                }
                seg.last
            }
            ServerResponse::InitiateDownload { .. } | ServerResponse::DownloadSegment { .. } => {
                self.sdo.get(&node).is_some_and(|t| t.ending)
            }
            ServerResponse::Abort { code, .. } => {
                self.sdo_abort(at, node, "server", code);
                return;
            }
            ServerResponse::BlockDownloadInitiate { .. }
            | ServerResponse::BlockDownloadAck { .. } => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.streaming = !t.ending;
                }
                false
            }
            ServerResponse::BlockDownloadEnd => true,
            ServerResponse::BlockUploadInitiate { size, .. } => {
                if let Some(t) = self.sdo.get_mut(&node) {
                    t.size = size;
                }
                false
            }
            ServerResponse::BlockUploadEnd { .. } => true,
        };
        if done {
            self.sdo.remove(&node);
        } else if let Some(t) = self.sdo.get_mut(&node) {
            t.last = at;
        }
    }
}
