//! The information sections: `[FileInfo]`, `[DeviceInfo]`, `[DeviceComissioning]` (CiA 306
//! §4.3, §4.4 and §4.7), `[Comments]`, `[DummyUsage]`, and the object lists
//! (`[MandatoryObjects]`, `[OptionalObjects]`, `[ManufacturerObjects]`, also the format of
//! `[xxxxObjectLinks]`).

use alloc::collections::BTreeMap;
use alloc::format;
use alloc::string::{String, ToString};
use alloc::vec::Vec;

use super::keys::{KeyTable, boolean, extra_owned, resolve_keys, uint, unquote};
use super::names::{hex4, strip_prefix_ci};
use super::section::Section;
use crate::diag::{DiagnosticKind as K, Echo, Sink};
use crate::model::{BAUD_RATES_KBIT, DeviceCommissioning, DeviceInfo, FileInfo};
use crate::value::{TextNotes, parse_int_literal};

/// `[MandatoryObjects]`-style lists and `[xxxxObjectLinks]`: `SupportedObjects=n` or
/// `ObjectLinks=n`, then `1=0x1000` ...
pub(super) fn object_list(sec: &Section<'_, '_>, sink: &mut Sink) -> Vec<u16> {
    let mut count: Option<(u64, u32)> = None;
    let mut items: BTreeMap<u64, (u16, u32)> = BTreeMap::new();
    for e in sec.entries.iter() {
        if e.key.eq_ignore_ascii_case("SupportedObjects")
            || e.key.eq_ignore_ascii_case("ObjectLinks")
        {
            count = uint(sink, (e.value, e.line), e.key, u64::MAX).map(|c| (c, e.line));
            continue;
        }
        let mut notes = TextNotes::default();
        let Some((n, _)) = parse_int_literal(e.key, &mut notes).filter(|(n, _)| *n >= 0) else {
            sink.warn(
                K::Structure,
                e.line,
                format!(
                    "[{}]: key `{}` is not a list position; ignored",
                    Echo(sec.name),
                    Echo(e.key)
                ),
            );
            continue;
        };
        let Some(index) = uint(sink, (e.value, e.line), "object index", 0xFFFF) else {
            continue;
        };
        if let Some((_, first)) = items.insert(n as u64, (index as u16, e.line)) {
            sink.warn(
                K::Duplicate,
                e.line,
                format!(
                    "[{}]: position {n} given again (first at line {first}); this value wins",
                    Echo(sec.name)
                ),
            );
        }
    }
    if let Some((c, line)) = count
        && c != items.len() as u64
    {
        sink.warn(
            K::ObjectList,
            line,
            format!(
                "[{}]: count says {c} but {} entries follow",
                Echo(sec.name),
                items.len()
            ),
        );
    }
    items.into_values().map(|(i, _)| i).collect()
}

pub(super) fn comments(sec: &Section<'_, '_>, sink: &mut Sink) -> Vec<String> {
    let mut lines: BTreeMap<u64, String> = BTreeMap::new();
    let mut declared = None;
    for e in sec.entries.iter() {
        if e.key.eq_ignore_ascii_case("Lines") {
            declared = uint(sink, (e.value, e.line), "Lines", u64::MAX).map(|c| (c, e.line));
        } else if let Some(n) = strip_prefix_ci(e.key, "Line").and_then(|n| n.parse::<u64>().ok()) {
            lines.insert(n, e.value.to_string());
        } else {
            sink.warn(
                K::Structure,
                e.line,
                format!("[Comments]: key `{}` ignored", Echo(e.key)),
            );
        }
    }
    if let Some((c, line)) = declared
        && c != lines.len() as u64
    {
        sink.warn(
            K::Structure,
            line,
            format!(
                "[Comments]: Lines={c} but {} LineN keys follow",
                lines.len()
            ),
        );
    }
    lines.into_values().collect()
}

pub(super) fn dummy_usage(sec: &Section<'_, '_>, sink: &mut Sink) -> BTreeMap<u16, bool> {
    let mut out = BTreeMap::new();
    for e in sec.entries.iter() {
        match strip_prefix_ci(e.key, "Dummy").and_then(hex4) {
            Some(dt) => {
                if let Some(b) = boolean(sink, (e.value, e.line), e.key) {
                    out.insert(dt, b);
                }
            }
            None => sink.warn(
                K::Structure,
                e.line,
                format!("[DummyUsage]: key `{}` ignored", Echo(e.key)),
            ),
        }
    }
    out
}

pub(super) const FILE_KEYS: KeyTable<11> = KeyTable::new([
    "FileName",
    "FileVersion",
    "FileRevision",
    "EDSVersion",
    "Description",
    "CreationTime",
    "CreationDate",
    "CreatedBy",
    "ModificationTime",
    "ModificationDate",
    "ModifiedBy",
]);

pub(super) fn file_info(sec: &Section<'_, '_>, sink: &mut Sink) -> FileInfo {
    let k = resolve_keys(sec, &FILE_KEYS, sink);
    let s = |i: usize| k.slots[i].map(|(t, _)| t.to_string());
    if let Some((v, line)) = k.slots[3]
        && v != "4.0"
    {
        sink.warn(
            K::Spelling,
            line,
            format!(
                "EDSVersion={}: CiA 306 v1.3 files say 4.0; read as 4.0",
                Echo(v)
            ),
        );
    }
    FileInfo {
        file_name: s(0),
        file_version: s(1),
        file_revision: s(2),
        eds_version: s(3),
        description: s(4),
        creation_time: s(5),
        creation_date: s(6),
        created_by: s(7),
        modification_time: s(8),
        modification_date: s(9),
        modified_by: s(10),
        extra: extra_owned(&k.extra),
    }
}

pub(super) const DEVICE_KEYS: KeyTable<23> = KeyTable::new([
    "VendorName",
    "VendorNumber",
    "ProductName",
    "ProductNumber",
    "RevisionNumber",
    "OrderCode",
    "BaudRate_10",
    "BaudRate_20",
    "BaudRate_50",
    "BaudRate_125",
    "BaudRate_250",
    "BaudRate_500",
    "BaudRate_800",
    "BaudRate_1000",
    "SimpleBootUpMaster",
    "SimpleBootUpSlave",
    "Granularity",
    "DynamicChannelsSupported",
    "GroupMessaging",
    "NrOfRXPDO",
    "NrOfTXPDO",
    "LSS_Supported",
    "CompactPDO",
]);

pub(super) fn device_info(sec: &Section<'_, '_>, sink: &mut Sink) -> DeviceInfo {
    let k = resolve_keys(sec, &DEVICE_KEYS, sink);
    let mut extra = extra_owned(&k.extra);
    // A known key whose value cannot be read is kept verbatim so the file round-trips.
    let mut num = |i: usize, max: u64| -> Option<u64> {
        let v = k.slots[i]?;
        let r = uint(sink, v, DEVICE_KEYS.keys[i], max);
        if r.is_none() {
            extra.push((DEVICE_KEYS.keys[i].into(), v.0.into()));
        }
        r
    };
    let vendor_number = num(1, u64::from(u32::MAX)).map(|v| v as u32);
    let product_number = num(3, u64::from(u32::MAX)).map(|v| v as u32);
    let revision_number = num(4, u64::from(u32::MAX)).map(|v| v as u32);
    let mut baud_rates = [None; 8];
    for (j, b) in baud_rates.iter_mut().enumerate() {
        *b = num(6 + j, u64::MAX).map(|v| v != 0);
    }
    let simple_boot_up_master = num(14, u64::MAX).map(|v| v != 0);
    let simple_boot_up_slave = num(15, u64::MAX).map(|v| v != 0);
    let granularity = num(16, 64).map(|v| v as u8);
    let dynamic_channels_supported = num(17, 255).map(|v| v as u8);
    let group_messaging = num(18, u64::MAX).map(|v| v != 0);
    let nr_of_rx_pdo = num(19, 512).map(|v| v as u16);
    let nr_of_tx_pdo = num(20, 512).map(|v| v as u16);
    let lss_supported = num(21, u64::MAX).map(|v| v != 0);
    let compact_pdo = num(22, 255).map(|v| v as u8);
    let vendor_name = k.slots[0].map(|v| unquote(sink, v, "VendorName").to_string());
    let product_name = k.slots[2].map(|v| unquote(sink, v, "ProductName").to_string());
    let order_code = k.slots[5].map(|v| unquote(sink, v, "OrderCode").to_string());
    let _ = BAUD_RATES_KBIT;
    DeviceInfo {
        vendor_name,
        vendor_number,
        product_name,
        product_number,
        revision_number,
        order_code,
        baud_rates,
        simple_boot_up_master,
        simple_boot_up_slave,
        granularity,
        dynamic_channels_supported,
        group_messaging,
        nr_of_rx_pdo,
        nr_of_tx_pdo,
        lss_supported,
        compact_pdo,
        extra,
    }
}

pub(super) const COMM_KEYS: KeyTable<7> = KeyTable::new([
    "NodeID",
    "NodeName",
    "Baudrate",
    "NetNumber",
    "NetworkName",
    "CANopenManager",
    "LSS_SerialNumber",
]);

pub(super) fn commissioning(sec: &Section<'_, '_>, sink: &mut Sink) -> DeviceCommissioning {
    let k = resolve_keys(sec, &COMM_KEYS, sink);
    let mut extra = extra_owned(&k.extra);
    let mut num = |i: usize, max: u64| -> Option<u64> {
        let v = k.slots[i]?;
        let r = uint(sink, v, COMM_KEYS.keys[i], max);
        if r.is_none() {
            extra.push((COMM_KEYS.keys[i].into(), v.0.into()));
        }
        r
    };
    let node_id = num(0, 255).map(|v| v as u8);
    let baudrate = num(2, 0xFFFF).map(|v| v as u16);
    let net_number = num(3, u64::from(u32::MAX)).map(|v| v as u32);
    let canopen_manager = num(5, u64::MAX).map(|v| v != 0);
    let lss_serial_number = num(6, u64::from(u32::MAX)).map(|v| v as u32);
    DeviceCommissioning {
        node_id,
        node_name: k.slots[1].map(|(t, _)| t.to_string()),
        baudrate,
        net_number,
        network_name: k.slots[4].map(|(t, _)| t.to_string()),
        canopen_manager,
        lss_serial_number,
        extra,
    }
}
