//! Reads a candump log (`candump -L`: `(time) iface ID#DATA`) and prints this crate's decoding
//! of every frame as tab-separated fields, for comparison with other decoders (the vcan rig
//! compares them with Wireshark's DeviceNet dissector):
//!
//! `can_id  group  message_id  mac  data_hex  dup_rr  dup_port  dup_vendor  dup_serial  text`
//!
//! Fields that do not apply are empty. Usage: `candump_fields LOG` (or the log on stdin).

use std::io::{BufRead, BufReader, Read};

use canola_devicenet::{Decoded, DnId};
use canola_frame::{CanFrame, CanId};

fn parse_line(line: &str) -> Option<CanFrame> {
    let frame = line.split_whitespace().nth(2)?;
    let (id, data) = frame.split_once('#')?;
    let id = u16::from_str_radix(id, 16).ok()?;
    if data.starts_with('R') {
        return CanFrame::remote(CanId::standard(id).ok()?, 0).ok();
    }
    let bytes: Option<Vec<u8>> = (0..data.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(data.get(i..i + 2)?, 16).ok())
        .collect();
    CanFrame::new(CanId::standard(id).ok()?, &bytes?).ok()
}

fn main() {
    let input: Box<dyn Read> = match std::env::args().nth(1) {
        Some(path) => Box::new(std::fs::File::open(&path).expect("the log opens")),
        None => Box::new(std::io::stdin()),
    };
    for line in BufReader::new(input).lines() {
        let line = line.expect("the log reads");
        let Some(frame) = parse_line(&line) else {
            continue;
        };
        let raw = frame.id().as_standard().unwrap_or(0);
        let (group, message, mac) = match DnId::from_raw(raw) {
            DnId::Group1 { message, mac } => ("1", message.to_string(), mac.get().to_string()),
            DnId::Group2 { mac, message } => ("2", message.to_string(), mac.get().to_string()),
            DnId::Group3 { message, mac } => ("3", message.to_string(), mac.get().to_string()),
            DnId::Group4 { message } => ("4", message.to_string(), String::new()),
            DnId::Invalid(_) => ("", String::new(), String::new()),
        };
        let data: String = frame.data().iter().map(|b| format!("{b:02x}")).collect();
        let decoded = canola_devicenet::decode(&frame);
        let dup = match decoded {
            Decoded::DuplicateMac { check: Ok(c), .. } => [
                (c.response as u8).to_string(),
                c.port.to_string(),
                c.vendor_id.to_string(),
                c.serial_number.to_string(),
            ],
            _ => Default::default(),
        };
        println!(
            "{raw}\t{group}\t{message}\t{mac}\t{data}\t{}\t{decoded}",
            dup.join("\t")
        );
    }
}
