//! A short walkthrough of a Bürkert device for `canopen demo`: the device status with the LED
//! colour drawn in the terminal, a locate, and a logbook download with progress.
//!
//! ```no_run
//! # use canola_burkert::{demo, BurkertDevice};
//! # use canola::{MemoryBus, Network};
//! # use canola_frame::NodeId;
//! let bus = MemoryBus::new();
//! let net = Network::new(bus.endpoint());
//! let id = NodeId::new(5).unwrap();
//! bus.attach(BurkertDevice::new(id));
//! net.add_node_with_dictionary(id, canola_burkert::master::generic_od().as_ref().clone());
//! demo::run(&net, id, &mut std::io::stdout()).unwrap();
//! ```

use std::io::Write;
use std::prelude::rust_2024::*;
use std::sync::{Arc, Mutex};
use std::{format, vec};

use canola::{Error, Network};
use canola_frame::NodeId;

use crate::colour::LedColour;
use crate::led::LedIndication;
use crate::master::{BurkertNode, DeviceReport};

/// How the walkthrough renders.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// Draw the LED colour with ANSI truecolor escapes (for a terminal).
    pub ansi: bool,
    /// Download the logbook by SDO block transfer (segmented otherwise).
    pub block: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            ansi: true,
            block: true,
        }
    }
}

/// What the walkthrough found, for callers that want more than the text.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The device read before the locate.
    pub report: DeviceReport,
    /// The logbook document.
    pub logbook: Vec<u8>,
    /// Progress reports of the logbook download: (bytes done, total).
    pub progress: Vec<(u64, Option<u64>)>,
}

/// The LED colour as a small swatch: a block in the colour (ANSI truecolor background) when
/// `ansi`, then the colour's name, and "flashing" while locating.
pub fn led_swatch(led: &LedIndication, ansi: bool) -> String {
    let mut s = String::new();
    if ansi {
        let (r, g, b) = led.colour.approx_rgb();
        s.push_str(&format!("\x1b[48;2;{r};{g};{b}m    \x1b[0m "));
    }
    s.push_str(&colour_name(led.colour));
    if led.flashing {
        s.push_str(" (flashing)");
    }
    s
}

fn colour_name(c: LedColour) -> String {
    match c {
        LedColour::Predefined(p) => format!("{} / {}", p.name(), p.name_de()),
        rgb => format!("{rgb}"),
    }
}

/// A text progress bar: `[#####.....]  2048/4096 bytes`.
pub fn progress_bar(done: u64, total: Option<u64>) -> String {
    const WIDTH: u64 = 30;
    match total {
        Some(t) if t > 0 => {
            let filled = (done.min(t) * WIDTH / t) as usize;
            format!(
                "[{}{}] {done}/{t} bytes",
                "#".repeat(filled),
                ".".repeat(WIDTH as usize - filled)
            )
        }
        _ => format!("{done} bytes"),
    }
}

/// Runs the walkthrough against the Bürkert device `node` with [`Options::default`].
pub fn run(network: &Network, node: NodeId, out: &mut impl Write) -> Result<Summary, Error> {
    run_with(network, node, out, Options::default())
}

/// Runs the walkthrough: reads the device (one batch of SDO reads), prints the status with the
/// LED colour, starts a locate and shows the LED again, then downloads the logbook with a
/// progress bar.
pub fn run_with(
    network: &Network,
    node: NodeId,
    out: &mut impl Write,
    options: Options,
) -> Result<Summary, Error> {
    let dev = BurkertNode::new(network.node(node));
    let report = dev.read_report()?;
    let d = &report.description;
    writeln!(
        out,
        "Bürkert device, node {}: {} (serial {}, software {:#010x})",
        node.get(),
        d.device_name.as_deref().unwrap_or("?"),
        d.serial_number.unwrap_or(0),
        d.software_version.unwrap_or(0),
    )?;
    let s = &report.status;
    if let Some(ne) = s.ne107 {
        writeln!(
            out,
            "  NE 107 status:  {} ({} / {})",
            ne.to_raw(),
            ne.meaning_en(),
            ne.meaning_de()
        )?;
    }
    if let Some(t) = s.temperature {
        writeln!(out, "  temperature:    {t}")?;
    }
    if let Some(v) = s.supply_voltage {
        writeln!(out, "  supply voltage: {v:.1} V")?;
    }
    if let Some(st) = report.communication.can_operation_status {
        writeln!(out, "  CAN status:     {st}")?;
    }
    writeln!(out, "  LED mode:       {}", report.led.mode)?;
    writeln!(
        out,
        "  LED:            {}",
        led_swatch(&report.led_indication(), options.ansi)
    )?;

    dev.start_locating()?;
    let after = dev.read_report()?;
    writeln!(
        out,
        "Locate started (the LED flashes for about 10 s): {}",
        led_swatch(&after.led_indication(), options.ansi)
    )?;

    let seen = Arc::new(Mutex::new(vec![]));
    let sink = seen.clone();
    let logbook = dev.read_logbook(options.block, move |p| {
        if let Ok(mut v) = sink.lock() {
            v.push((p.done, p.total));
        }
    })?;
    let progress = seen.lock().map(|v| v.clone()).unwrap_or_default();
    writeln!(
        out,
        "Logbook download (0x2003 sub 4, {} transfer):",
        if options.block { "block" } else { "segmented" }
    )?;
    // Four steps of the bar, then the final state.
    let total = progress.last().and_then(|p| p.1);
    let mut next_quarter = 1u64;
    for &(done, t) in &progress {
        let reached = t.is_some_and(|t| t > 0 && done * 4 >= next_quarter * t);
        if reached && next_quarter < 4 {
            writeln!(out, "  {}", progress_bar(done, t))?;
            next_quarter += 1;
        }
    }
    writeln!(out, "  {}", progress_bar(logbook.len() as u64, total))?;
    let text = String::from_utf8_lossy(&logbook);
    let entries = text.matches("<entry ").count();
    writeln!(
        out,
        "  {} bytes of XML, {entries} entries; first line: {}",
        logbook.len(),
        text.lines().next().unwrap_or("")
    )?;
    Ok(Summary {
        report,
        logbook,
        progress,
    })
}
