//! CANopen network management and error control (CiA 301 §7.2.5–§7.2.8, §7.3.2), sans-IO.
//!
//! Two layers:
//! - **Codecs** turn the data bytes of one service into a typed value and back. Parsing never
//!   panics and keeps unknown wire codes, so decode-encode round trips are lossless:
//!   [`NmtCommand`] (module control, COB-ID 0x000), [`Heartbeat`] and [`GuardResponse`]
//!   (0x700 + node; [`ErrorControlMessage`] is any frame there with its node), [`SyncMessage`],
//!   [`TimeOfDay`], [`Emcy`] with [`EmcyCode`] and [`ErrorRegister`]. Each has a `Display`
//!   text in CiA 301 words (`NMT Start remote node, all nodes`, `heartbeat node 5
//!   Operational`, `EMCY 0x5000 (device hardware), error register 0x01 (generic)`), as do the
//!   machines' events.
//! - **Machines** are fed with frames and the current [`Instant`] and hand back frames to send,
//!   events and their next deadline. They never read a clock or touch I/O.
//!   - Master side: [`HeartbeatConsumer`], [`GuardingMaster`], [`SyncProducer`],
//!     [`TimeProducer`], [`EmcyConsumer`].
//!   - Device side: [`NmtSlave`] (with [`HeartbeatProducer`] and [`GuardingResponder`] inside),
//!     [`EmcyProducer`].
//!
//! Every machine follows the same call order:
//! 1. configure it (`new`, `monitor`, `guard`, `start`, `boot`, ...);
//! 2. for each received frame call `handle_frame(now, &frame)`; it returns `Ok(false)` for frames
//!    that are not its business, so a router may offer a frame to several machines;
//! 3. when `poll_timeout()` is at or before the current time, call `handle_timeout(now)`;
//! 4. after each of these calls drain `poll_transmit()` (typed messages) or its frame adapter
//!    `poll_transmit_frame()` (frames to put on the bus) and `poll_event()` until they return
//!    `None`, then sleep until the new `poll_timeout()` or the next frame.
//!
//! The producers' periods run on [`canola_frame::Periodic`]; a driver tests a machine's deadline
//! with [`canola_frame::is_due`] and folds several with [`canola_frame::earliest`].
//!
//! ```
//! use canola_nmt::{Duration, Heartbeat, HeartbeatConsumer, HeartbeatEvent, Instant, NmtState, NodeId};
//!
//! let node = NodeId::new(5).unwrap();
//! let mut monitor = HeartbeatConsumer::<8>::new();
//! monitor.monitor(node, Duration::from_millis(750)).unwrap(); // 0x1016 entry 0x0005_02EE
//! assert_eq!(monitor.poll_timeout(), None); // armed only by the first heartbeat
//!
//! let frame = Heartbeat { state: NmtState::Operational }.to_frame(node); // 705#05
//! assert_eq!(monitor.handle_frame(Instant::from_millis(100), &frame), Ok(true));
//! assert!(matches!(monitor.poll_event(), Some(HeartbeatEvent::StateChanged { .. })));
//! assert_eq!(monitor.poll_timeout(), Some(Instant::from_millis(850)));
//!
//! monitor.handle_timeout(Instant::from_millis(850));
//! assert_eq!(
//!     monitor.poll_event(),
//!     Some(HeartbeatEvent::Lost { node, last_state: Some(NmtState::Operational) })
//! );
//! ```
//!
//! The crate is `#![no_std]` without an allocator; bounded tables use `heapless`. The `std`
//! feature (default) adds [`TimeOfDay::from_system_time`] and [`TimeOfDay::to_system_time`].
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]

#[cfg(feature = "std")]
extern crate std;

/// Implements `Debug` as the `Display` text for this crate's error types (the error
/// convention in `docs/STYLE.md`): a `main` that returns one of them with `?` prints readable
/// English, not the structure; a program inspects the structure through its fields.
macro_rules! debug_as_display {
    ($name:ident $(<$($g:ident),+>)?) => {
        impl$(<$($g),+>)? core::fmt::Debug for $name$(<$($g),+>)?
        where
            Self: core::fmt::Display,
        {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                core::fmt::Display::fmt(self, f)
            }
        }
    };
}

mod command;
mod emcy;
mod error;
mod error_control;
mod guarding;
mod heartbeat;
mod slave;
mod state;
mod sync;
mod time_stamp;
mod util;

pub use canola_frame::{CanFrame, Duration, Instant, NodeId};
pub use command::{CommandSpecifier, NMT_COB_ID, NmtCommand, NmtTarget};
pub use emcy::{
    EMCY_EVENT_CAPACITY, EMCY_QUEUE_CAPACITY, Emcy, EmcyCode, EmcyConsumer, EmcyEvent,
    EmcyProducer, ErrorRegister, emcy_cob_id,
};
pub use error::{CapacityError, ConfigError, DecodeError};
pub use error_control::{
    ErrorControlFrame, ErrorControlMessage, GuardResponse, Heartbeat, error_control_cob_id,
    guard_request,
};
pub use guarding::{
    GUARDING_EVENT_CAPACITY, GuardingEvent, GuardingMaster, GuardingResponder, LifeGuardingEvent,
};
pub use heartbeat::{
    ConsumerHeartbeatEntry, HEARTBEAT_EVENT_CAPACITY, HeartbeatConsumer, HeartbeatEvent,
    HeartbeatProducer,
};
pub use slave::{NmtSlave, SlaveConfig, SlaveEvent};
pub use state::{DeviceState, NmtState, Service};
pub use sync::{SYNC_COB_ID, SyncConfig, SyncMessage, SyncProducer};
pub use time_stamp::{EPOCH_1984_UNIX_DAYS, TIME_COB_ID, TimeOfDay, TimeProducer};

/// This crate's README, whose example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod crate_readme {}

/// The error convention (`docs/STYLE.md`): `Debug` prints the `Display` text, so a `main` that
/// returns this crate's error with `?` prints `Error: ` and the text.
#[cfg(test)]
mod error_convention {
    extern crate std;
    use std::{format, string::ToString};

    #[test]
    fn main_prints_the_text() {
        let e = crate::NmtCommand::parse(&[1]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "NMT module control: unexpected data length 1"
        );
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
