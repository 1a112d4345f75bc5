//! The simulated device's logbook: the entries it has from before the simulation, one per event
//! of the simulation, and the XML document 0x2003 sub 4 serves as a DOMAIN.

use std::prelude::rust_2024::*;

use std::fmt::Write as _;

use canola::Values;

use super::{HISTORIC_LOG_ENTRIES, Shared};
use crate::ne107::Ne107Status;

#[derive(Debug, Clone)]
pub(super) struct LogEntry {
    /// Seconds relative to the start of the simulation (negative: history).
    pub(super) time_s: f64,
    pub(super) status: Ne107Status,
    pub(super) source: &'static str,
    pub(super) text: String,
}

impl Shared {
    pub(super) fn logbook_xml(&self, values: &Values) -> Vec<u8> {
        let name = values
            .get(0x2000, 1)
            .map(|b| String::from_utf8_lossy(b).into_owned())
            .unwrap_or_default();
        let serial = values.get_u64(0x2000, 7).unwrap_or(0);
        let mut x = String::with_capacity(4096 + 96 * self.log.len());
        x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
        let _ = writeln!(
            x,
            "<logbook device=\"{}\" serial=\"{serial}\" node-id=\"{}\" boots=\"{}\">",
            xml_escape(&name),
            self.node.get(),
            self.boots
        );
        for (i, e) in self.log.iter().enumerate() {
            let _ = writeln!(
                x,
                "  <entry id=\"{}\" time-s=\"{:.3}\" ne107=\"{}\" source=\"{}\">{}</entry>",
                i + 1,
                e.time_s,
                e.status.to_raw(),
                e.source,
                xml_escape(&e.text)
            );
        }
        x.push_str("</logbook>\n");
        x.into_bytes()
    }
}

fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

pub(super) fn history() -> Vec<LogEntry> {
    const TEXTS: [(&str, Ne107Status); 6] = [
        ("device started", Ne107Status::DiagnosisInactive),
        (
            "supply voltage below 18 V for 120 ms",
            Ne107Status::OutOfSpecification,
        ),
        (
            "supply voltage back in range",
            Ne107Status::DiagnosisInactive,
        ),
        (
            "maintenance interval reached (100000 switching cycles)",
            Ne107Status::MaintenanceRequired,
        ),
        ("maintenance acknowledged", Ne107Status::DiagnosisInactive),
        (
            "parameter set changed over bUS",
            Ne107Status::DiagnosisActive,
        ),
    ];
    (0..HISTORIC_LOG_ENTRIES)
        .map(|i| {
            let (text, status) = TEXTS[i % TEXTS.len()];
            LogEntry {
                time_s: -3600.0 * (HISTORIC_LOG_ENTRIES - i) as f64,
                status,
                source: "history",
                text: text.into(),
            }
        })
        .collect()
}
