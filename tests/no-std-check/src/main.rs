//! no_std link check: see Cargo.toml. Each core crate is named with `extern crate` so it is
//! linked even though nothing here calls it.
#![no_std]
#![no_main]

extern crate canola_burkert;
extern crate canola_cia402;
extern crate canola_devicenet;
extern crate canola_frame;
extern crate canola_gemu;
extern crate canola_lss;
extern crate canola_nmt;
extern crate canola_od;
extern crate canola_pdo;
extern crate canola_sdo;
extern crate canola_slcan;

use core::panic::PanicInfo;

#[panic_handler]
fn panic(_info: &PanicInfo<'_>) -> ! {
    loop {}
}

/// The host's precompiled `core` is built with unwinding and so refers to this symbol; with
/// `panic = "abort"` it is never called.
#[unsafe(no_mangle)]
pub extern "C" fn rust_eh_personality() {}

// The C start files call `main` through `__libc_start_main`: link the C library for that alone.
#[link(name = "c")]
unsafe extern "C" {}

/// The C runtime's entry point calls `main`; this binary is only linked, never run.
#[unsafe(no_mangle)]
pub extern "C" fn main(_argc: i32, _argv: *const *const u8) -> i32 {
    // Touch one item so the crate is really used, not only declared.
    let id = canola_frame::NodeId::new(5);
    let colour = canola_burkert::LedColour::from_u32(0x1000_0002);
    let heartbeat = canola_nmt::Heartbeat::parse(&[0x7F]);
    let sdo = canola_sdo::ClientRequest::parse(&[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]);
    let mut server = canola_sdo::Server::new(canola_sdo::ServerConfig::default());
    let dn = canola_devicenet::DuplicateMacCheck::parse(&[0; 7]);
    let plan = canola_cia402::Planner::default().plan(
        canola_cia402::Statusword::from_raw(0x0250),
        canola_cia402::State::OperationEnabled,
    );
    let slcan_items = canola_slcan::Decoder::new().feed(b"t1230\r").count();
    if id.is_ok()
        && colour.is_ok()
        && heartbeat.is_ok()
        && sdo.is_ok()
        && dn.is_ok()
        && plan.is_ok()
        && slcan_items == 1
        && server.poll_transmit().is_none()
    {
        0
    } else {
        1
    }
}
