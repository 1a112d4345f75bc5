//! Carrying out one request on a [`Network`]: SDO upload and download (started as [`Pending`]
//! requests, answered when they end), NMT, the LSS services (blocking), and the mapping of the
//! master's errors to the replies of CiA 309-3 (an SDO abort code as `ERROR:0x........`, a
//! local failure as a gateway error code).

use std::io::Write;
use std::sync::{Arc, Mutex};

use canola::frame::{Duration, NodeId};
use canola::lss::{
    AddressPart, AssignConfig, BitTiming, FastscanConfig, LssAddress, LssError, Mode, NodeIdPool,
    Procedure, ResponseError, Service, Step,
};
use canola::{Error, Network, Pending, SdoErrorKind};

use crate::command::{AllNodes, Command, ErrorCode, NmtService, Reply, ScanType};
use crate::value::{DataType, Value};

/// SDO abort 0x05040005: out of memory (an upload longer than the gateway takes).
const ABORT_OUT_OF_MEMORY: u32 = 0x0504_0005;
/// SDO abort 0x06070010: data type does not match, length of service parameter does not match.
const ABORT_TYPE_LENGTH: u32 = 0x0607_0010;

/// The reply for a failed request of the master API.
pub(crate) fn error_reply(e: &Error) -> Reply {
    match e {
        Error::Sdo(e) => match &e.kind {
            SdoErrorKind::Transfer(k) => Reply::Abort(k.abort_code().get()),
            SdoErrorKind::Io { .. } => Reply::Abort(ABORT_OUT_OF_MEMORY),
            _ => Reply::Error(ErrorCode::INTERNAL_STATE),
        },
        Error::Timeout { .. } => Reply::Error(ErrorCode::TIMEOUT),
        Error::Lss(e) => Reply::Error(lss_error(e)),
        _ => Reply::Error(ErrorCode::INTERNAL_STATE),
    }
}

fn lss_error(e: &LssError) -> ErrorCode {
    match e {
        LssError::Timeout { .. } => ErrorCode::TIMEOUT,
        LssError::Rejected { service, error } => match (service, error) {
            (_, ResponseError::VendorSpecific(_)) => ErrorCode::LSS_MANUFACTURER,
            (_, ResponseError::StorageMediaAccess) => ErrorCode::LSS_MEDIA_ERROR,
            (Service::ConfigureNodeId, _) => ErrorCode::LSS_NODE_ID_NOT_SUPPORTED,
            (Service::ConfigureBitTiming, _) => ErrorCode::LSS_BIT_RATE_NOT_SUPPORTED,
            (Service::StoreConfiguration, _) => ErrorCode::LSS_STORE_FAILED,
            _ => ErrorCode::LSS_MANUFACTURER,
        },
        _ => ErrorCode::INTERNAL_STATE,
    }
}

/// A writer that keeps at most `limit` bytes and fails past them (the transfer is then
/// aborted), so a client cannot make the gateway hold an unbounded upload.
struct Bounded {
    buf: Arc<Mutex<Vec<u8>>>,
    limit: usize,
}

impl Write for Bounded {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        let mut b = self
            .buf
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if b.len() + data.len() > self.limit {
            return Err(std::io::Error::other(
                "upload longer than the gateway takes",
            ));
        }
        b.extend_from_slice(data);
        Ok(data.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The SDO settings a request runs with (the client's, when it was read).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SdoSettings {
    pub(crate) timeout: Duration,
    pub(crate) block: bool,
    pub(crate) max_upload: usize,
}

/// An SDO request in flight ([`Pending`]), and what its reply is made from when it ends.
pub(crate) enum Transfer {
    /// An upload into a bounded buffer, shown as `data_type` when it ends.
    Read {
        pending: Pending<u64>,
        buf: Arc<Mutex<Vec<u8>>>,
        data_type: DataType,
    },
    Write(Pending<()>),
}

impl Transfer {
    /// Whether the request has ended (its reply is ready).
    pub(crate) fn is_done(&self) -> bool {
        match self {
            Self::Read { pending, .. } => pending.is_done(),
            Self::Write(pending) => pending.is_done(),
        }
    }

    /// The reply, once the request has ended ([`is_done`](Self::is_done); before that this
    /// blocks, driving the network, until it ends).
    pub(crate) fn reply(self) -> Reply {
        match self {
            Self::Read {
                pending,
                buf,
                data_type,
            } => {
                if let Err(e) = pending.wait() {
                    return error_reply(&e.into());
                }
                let bytes = std::mem::take(
                    &mut *buf
                        .lock()
                        .unwrap_or_else(std::sync::PoisonError::into_inner),
                );
                match Value::from_le_bytes(data_type, &bytes) {
                    Ok(v) => Reply::Text(v.to_string()),
                    Err(_) => Reply::Abort(ABORT_TYPE_LENGTH),
                }
            }
            Self::Write(pending) => match pending.wait() {
                Ok(()) => Reply::Ok,
                Err(e) => error_reply(&e.into()),
            },
        }
    }
}

/// Starts an SDO upload, to be shown as `data_type` (else the dictionary's type, else `hex`).
pub(crate) fn submit_read(
    net: &Network,
    node: NodeId,
    index: u16,
    sub: u8,
    data_type: Option<DataType>,
    s: SdoSettings,
) -> Transfer {
    let n = net.node(node);
    let data_type = data_type
        .or_else(|| {
            n.dictionary()
                .and_then(|od| od.sub(index, sub).map(|e| e.data_type))
                .and_then(DataType::from_od)
        })
        .unwrap_or(DataType::Hex);
    let buf = Arc::new(Mutex::new(Vec::new()));
    let sink = Bounded {
        buf: buf.clone(),
        limit: s.max_upload,
    };
    let pending = n
        .sdo()
        .timeout(s.timeout)
        .block(s.block)
        .submit_upload_to((index, sub), sink);
    Transfer::Read {
        pending,
        buf,
        data_type,
    }
}

/// Starts an SDO download.
pub(crate) fn submit_write(
    net: &Network,
    node: NodeId,
    index: u16,
    sub: u8,
    value: &Value,
    s: SdoSettings,
) -> Transfer {
    Transfer::Write(
        net.node(node)
            .sdo()
            .timeout(s.timeout)
            .block(s.block)
            .submit_write((index, sub), value.to_le_bytes()),
    )
}

/// NMT module control; node 0 is every node.
pub(crate) fn nmt(net: &Network, node: u8, service: NmtService) -> Reply {
    use canola::nmt::CommandSpecifier as Cs;
    let cs = match service {
        NmtService::Start => Cs::Start,
        NmtService::Stop => Cs::Stop,
        NmtService::PreOperational => Cs::EnterPreOperational,
        NmtService::ResetNode => Cs::ResetNode,
        NmtService::ResetCommunication => Cs::ResetCommunication,
    };
    let r = match NodeId::new(node) {
        Ok(id) => {
            let nmt = net.node(id).nmt();
            match service {
                NmtService::Start => nmt.start(),
                NmtService::Stop => nmt.stop(),
                NmtService::PreOperational => nmt.enter_preoperational(),
                NmtService::ResetNode => nmt.reset_node(),
                NmtService::ResetCommunication => nmt.reset_communication(),
            }
        }
        Err(_) => net.nmt_all(cs),
    };
    match r {
        Ok(()) => Reply::Ok,
        Err(e) => error_reply(&e),
    }
}

fn address_text(a: &LssAddress) -> String {
    format!(
        "0x{:08X} 0x{:08X} 0x{:08X} 0x{:08X}",
        a.vendor_id, a.product_code, a.revision_number, a.serial_number
    )
}

fn step(net: &Network, step: Step) -> Result<canola::lss::ServiceReport, Reply> {
    net.lss()
        .procedure(Procedure::single(step))
        .wait()
        .map_err(|e| error_reply(&e))
}

/// The LSS services (CiA 305); one runs at a time on a network.
pub(crate) fn lss(net: &Network, command: &Command) -> Reply {
    let ok = |r: Result<canola::lss::ServiceReport, Reply>| r.map_or_else(|e| e, |_| Reply::Ok);
    match *command {
        Command::LssSwitchGlobal(config) => ok(step(
            net,
            Step::SwitchModeGlobal(if config {
                Mode::Configuration
            } else {
                Mode::Waiting
            }),
        )),
        Command::LssSwitchSelective([v, p, r, s]) => ok(step(
            net,
            Step::SwitchModeSelective(LssAddress {
                vendor_id: v,
                product_code: p,
                revision_number: r,
                serial_number: s,
            }),
        )),
        Command::LssSetNode(n) => ok(step(net, Step::ConfigureNodeId(n))),
        Command::LssConfBitrate { table, index } => ok(step(
            net,
            Step::ConfigureBitTiming(BitTiming { table, index }),
        )),
        Command::LssActivateBitrate(delay_ms) => {
            ok(step(net, Step::ActivateBitTiming { delay_ms }))
        }
        Command::LssStore => ok(step(net, Step::StoreConfiguration)),
        Command::LssInquireAddr(Some(part)) => {
            let Some(part) = AddressPart::from_index(part) else {
                return Reply::Error(ErrorCode::SYNTAX);
            };
            match step(net, Step::InquireIdentity(part)) {
                Ok(r) => match r.identity[usize::from(part.index())] {
                    Some(v) => Reply::Text(format!("0x{v:08X}")),
                    None => Reply::Error(ErrorCode::TIMEOUT),
                },
                Err(e) => e,
            }
        }
        Command::LssInquireAddr(None) => match net.lss().procedure(Procedure::inquire_all()).wait()
        {
            Ok(r) => match r.address() {
                Some(a) => Reply::Text(address_text(&a)),
                None => Reply::Error(ErrorCode::TIMEOUT),
            },
            Err(e) => error_reply(&e),
        },
        Command::LssGetNode => match step(net, Step::InquireNodeId) {
            Ok(r) => match r.node_id {
                Some(n) => Reply::Text(n.to_string()),
                None => Reply::Error(ErrorCode::TIMEOUT),
            },
            Err(e) => e,
        },
        Command::LssFastscan(timeout) => {
            let mut cfg = FastscanConfig::default();
            // 0: the default, as in CANopenNode.
            if let Some(ms) = timeout.filter(|&ms| ms != 0) {
                cfg.response_timeout = Duration::from_millis(ms.into());
            }
            match net.lss().fastscan(cfg).wait() {
                Ok(Some(a)) => Reply::Text(address_text(&a)),
                Ok(None) => Reply::Error(ErrorCode::TIMEOUT),
                Err(e) => error_reply(&e),
            }
        }
        Command::LssAllNodes(args) => all_nodes(net, args),
        _ => Reply::Error(ErrorCode::REQUEST_NOT_SUPPORTED),
    }
}

/// `lss_allnodes`: every unconfigured slave gets the next free node-ID from `node_start` on.
/// The report is CANopenNode's: a comment line `# Node-ID <n> assigned to: <vendor> <product>
/// <revision> <serial>` for each slave (a part that scan type 1 ignores reads 0, as Fastscan
/// never learns it), then `# Found <count> nodes, search finished.` (or `# Not all nodes
/// scanned!` when the node-IDs ran out), then `OK`. Scan types that leave no Fastscan (the
/// vendor-ID ignored, or all three parts after it) answer 101.
fn all_nodes(net: &Network, args: Option<AllNodes>) -> Reply {
    let mut start = 2u8;
    let mut cfg = AssignConfig::with_pool(NodeIdPool::all());
    cfg.store = true;
    if let Some(a) = args {
        // 0: the default, as in CANopenNode.
        if a.timeout_ms != 0 {
            cfg.fastscan.response_timeout = Duration::from_millis(a.timeout_ms.into());
        }
        if let Some(asg) = a.assign {
            start = asg.node_start;
            cfg.store = asg.store;
            if let Some(scan) = asg.scan {
                for (i, (t, v)) in scan.iter().enumerate() {
                    match t {
                        ScanType::Scan => {}
                        ScanType::Ignore => cfg.fastscan.skip[i] = true,
                        ScanType::Match => cfg.fastscan.known[i] = Some(*v),
                    }
                }
                // Fastscan cannot skip the vendor-ID, nor every part after it
                // (CANopenNode's master refuses these as illegal arguments too).
                if cfg.fastscan.validate().is_err() {
                    return Reply::Error(ErrorCode::SYNTAX);
                }
            }
        }
    }
    let (Ok(first), Ok(last)) = (NodeId::new(start), NodeId::new(127)) else {
        return Reply::Error(ErrorCode::UNSUPPORTED_NODE);
    };
    cfg.pool = NodeIdPool::range(first, last);
    match net.lss().assign_all(cfg).wait() {
        Ok(report) => {
            let mut lines: Vec<String> = report
                .assigned()
                .map(|(a, n)| format!("# Node-ID {} assigned to: {}", n.get(), address_text(&a)))
                .collect();
            let count = lines.len();
            match report.stopped {
                Some(LssError::NoFreeNodeId) => lines.push("# Not all nodes scanned!".into()),
                Some(e) if count == 0 => return Reply::Error(lss_error(&e)),
                _ => lines.push(format!("# Found {count} nodes, search finished.")),
            }
            Reply::Lines(lines)
        }
        Err(e) => error_reply(&e),
    }
}
