//! Faults the bus reports: error frames (Linux `can/error.h` classes, the controller's
//! error-passive and bus-off states) and EMCY messages with their codes' meanings and the error
//! register (CiA 402 codes for a drive).

use super::*;

impl Analyzer {
    pub(super) fn error_frame(&mut self, line: usize, t: u64, class: u32, data: &[u8; 8]) {
        self.error_frames += 1;
        // Linux can/error.h: the class bits and the controller status in data[1].
        let (level, what, meaning) = if class & 0x40 != 0 {
            (
                Level::Error,
                "bus-off",
                "the controller left the bus after too many transmit errors (wiring, \
                 termination, bit rate, a faulty node)",
            )
        } else if class & 0x04 != 0 && data[1] & 0x30 != 0 {
            (
                Level::Warning,
                "controller error-passive",
                "error counters above 127: the bus has frequent errors (wiring, termination, \
                 bit rate)",
            )
        } else if class & 0x20 != 0 {
            (
                Level::Warning,
                "no acknowledgement",
                "nobody acknowledged a frame: no other node is on the bus, or it uses another \
                 bit rate",
            )
        } else if class & 0x08 != 0 {
            (
                Level::Warning,
                "protocol violation",
                "bit, form or stuff errors on the bus (noise, termination, bit timing)",
            )
        } else {
            (
                Level::Warning,
                "error frame",
                "the controller reported an error on the bus",
            )
        };
        let seen = format!("{what} (error class {class:#x}, data {})", hex(data));
        self.problem(
            t,
            Some(line),
            None,
            level,
            Kind::ErrorFrame,
            seen,
            meaning.into(),
        );
    }

    pub(super) fn emcy(&mut self, line: usize, t: u64, n: u8, frame: &CanFrame) {
        let seen = self.seen(frame);
        let Ok(emcy) = Emcy::parse(frame.data()) else {
            self.problem(
                t,
                Some(line),
                Some(n),
                Level::Warning,
                Kind::Emcy,
                seen,
                "an EMCY of the wrong length (CiA 301 EMCY carries 8 bytes)".into(),
            );
            return;
        };
        let node = &mut self.nodes[usize::from(n)];
        node.summary.emcys += 1;
        let drive = node.drive;
        if emcy.code.is_reset() {
            self.event(t, Some(n), format!("node {n}: EMCY error reset"));
            return;
        }
        let profile = drive
            .then(|| canola_cia402::ErrorCode(emcy.code.0).name())
            .flatten();
        let what = match (profile, emcy.code.description()) {
            (Some(p), _) => format!("CiA 402: {p}"),
            (None, Some(d)) => d.to_string(),
            (None, None) => "a manufacturer-specific error".into(),
        };
        self.problem(
            t,
            Some(line),
            Some(n),
            Level::Error,
            Kind::Emcy,
            seen,
            format!(
                "node {n} signals {what} (error register {:#04x}: {})",
                emcy.register.0, emcy.register
            ),
        );
    }
}
