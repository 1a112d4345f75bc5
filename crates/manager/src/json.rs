//! The reports as JSON, the form `canopen boot --json` and `canopen audit --json` print:
//! `{"slaves": [{"node_id": 5, "status": "operational", "error_code": null, ...}], ...}`.

use serde_json::{Value as Json, json};

use crate::audit::AuditReport;
use crate::boot::{BootReport, ConfigOutcome, SlaveReport, SoftwareOutcome};

fn micros(d: canola::Duration) -> u64 {
    d.as_micros()
}

/// One slave's boot as JSON.
pub fn slave_json(s: &SlaveReport) -> Json {
    let (configured, written) = match s.configuration {
        ConfigOutcome::NotRun => (Json::Null, Json::Null),
        ConfigOutcome::Written(n) => (json!("written"), json!(n)),
        ConfigOutcome::Verified => (json!("verified"), json!(0)),
    };
    json!({
        "node_id": s.node_id.get(),
        "mandatory": s.mandatory,
        "status": s.status.name(),
        "error_code": s.error_code.map(|c| c.letter().to_string()),
        "error": s.error_code.map(|c| c.meaning()),
        "step": s.step.map(|st| st.name()),
        "object": s.object.map(|o| o.to_string()),
        "abort_code": s.abort_code.map(|c| format!("{c:#010x}")),
        "detail": s.detail,
        "software": match s.software {
            SoftwareOutcome::NotChecked => Json::Null,
            SoftwareOutcome::Verified => json!("verified"),
            SoftwareOutcome::Updated => json!("updated"),
        },
        "configuration": configured,
        "values_written": written,
        "error_control": s.error_control,
        "elapsed_us": micros(s.elapsed),
    })
}

/// The whole boot as JSON.
pub fn boot_json(r: &BootReport) -> Json {
    json!({
        "slaves": r.slaves.iter().map(slave_json).collect::<Vec<_>>(),
        "mandatory_ok": r.mandatory_ok,
        "elapsed_us": micros(r.elapsed),
        "wall_us": r.wall.as_micros() as u64,
    })
}

/// The audit as JSON.
pub fn audit_json(r: &AuditReport) -> Json {
    let slaves: Vec<Json> = r
        .slaves
        .iter()
        .map(|s| {
            json!({
                "node_id": s.node_id.get(),
                "checked": s.checked,
                "differences": s.differences.iter().map(|d| json!({
                    "object": d.object.to_string(),
                    "name": d.name,
                    "type": format!("{:?}", d.data_type),
                    "expected": d.expected.to_string(),
                    "actual": d.actual.as_ref().map(ToString::to_string),
                    "fixed": d.fixed.as_ref().map(|f| f.is_ok()),
                    "fix_error": d.fixed.as_ref().and_then(|f| f.as_ref().err().cloned()),
                })).collect::<Vec<_>>(),
                "unreadable": s.unreadable.iter().map(|u| json!({
                    "object": u.object.to_string(),
                    "name": u.name,
                    "error": u.error,
                    "abort_code": u.abort_code.map(|c| format!("{c:#010x}")),
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({ "slaves": slaves, "clean": r.is_clean() })
}
