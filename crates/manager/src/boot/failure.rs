//! The pieces the per-slave boot shares: a failed step as it ends a slave's boot, and the
//! checks of values read against the DCF.

use canola::{Error, ObjectAddress, SdoErrorKind};

use super::report::BootStep;
use crate::codes::BootErrorCode;
use crate::config::SlaveConfig;

/// A failed step, as a slave's boot ends with it.
pub(super) struct Failure {
    pub(super) step: BootStep,
    pub(super) code: BootErrorCode,
    pub(super) object: Option<ObjectAddress>,
    pub(super) abort: Option<u32>,
    pub(super) detail: String,
    pub(super) absent: bool,
}

impl Failure {
    /// The failure of an SDO transfer at `at` (the object the SDO error names, when it is
    /// one).
    pub(super) fn sdo(step: BootStep, code: BootErrorCode, at: ObjectAddress, e: &Error) -> Self {
        let (object, abort) = match e {
            Error::Sdo(e) => (e.entry, e.abort_code().map(|c| c.get())),
            _ => (at, None),
        };
        Self {
            step,
            code,
            object: Some(object),
            abort,
            detail: e.to_string(),
            absent: false,
        }
    }

    /// The keep-alive check at `step` failed: by node guarding (0x100C, code F) or by the
    /// heartbeat (0x1017): code K while error control starts, else code E (CiA 302-2).
    pub(super) fn keep_alive(step: BootStep, guarding: bool, detail: String) -> Self {
        let (code, index) = match (guarding, step) {
            (true, _) => (BootErrorCode::F, 0x100C),
            (false, BootStep::ErrorControl) => (BootErrorCode::K, 0x1017),
            (false, _) => (BootErrorCode::E, 0x1017),
        };
        Self {
            step,
            code,
            object: Some(ObjectAddress::new(index, 0)),
            abort: None,
            detail,
            absent: false,
        }
    }
}

pub(super) fn to_u32(bytes: &[u8]) -> u32 {
    let mut b = [0u8; 4];
    let n = bytes.len().min(4);
    b[..n].copy_from_slice(&bytes[..n]);
    u32::from_le_bytes(b)
}

/// Whether the SDO failed by the response timeout.
pub(super) fn is_timeout(e: &Error) -> bool {
    matches!(
        e,
        Error::Sdo(e) if matches!(e.kind, SdoErrorKind::Transfer(canola::sdo::ErrorKind::Timeout))
    )
}

pub(super) fn mismatch(
    code: BootErrorCode,
    at: ObjectAddress,
    expected: u32,
    actual: u32,
) -> Failure {
    Failure {
        step: BootStep::Identity,
        code,
        object: Some(at),
        abort: None,
        detail: format!("{at} is {actual:#010x}, expected {expected:#010x}"),
        absent: false,
    }
}

/// The configuration date and time 0x1020:01/02 the DCF records, when it records one.
pub(super) fn verify_stamp(slave: &SlaveConfig) -> Option<(u32, u32)> {
    let get = |sub| {
        let s = slave.dictionary.sub(0x1020, sub)?;
        let v = s.parameter_value()?.resolve(slave.node_id.get())?;
        // A UNSIGNED32 from a DCF, or four bytes from a concise DCF.
        <[u8; 4]>::try_from(v.to_le_bytes().as_slice())
            .ok()
            .map(u32::from_le_bytes)
    };
    let stamp = (get(1)?, get(2)?);
    (stamp != (0, 0)).then_some(stamp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_keep_alive_failure_names_its_code_and_object() {
        let cases = [
            (BootStep::NodeState, true, BootErrorCode::F, 0x100C),
            (BootStep::ErrorControl, true, BootErrorCode::F, 0x100C),
            (BootStep::NodeState, false, BootErrorCode::E, 0x1017),
            (BootStep::ErrorControl, false, BootErrorCode::K, 0x1017),
        ];
        for (step, guarding, code, index) in cases {
            let f = Failure::keep_alive(step, guarding, "why".into());
            assert_eq!((f.step, f.code), (step, code));
            assert_eq!(f.object, Some(ObjectAddress::new(index, 0)));
            assert_eq!((f.abort, f.detail.as_str(), f.absent), (None, "why", false));
        }
    }
}
