//! PDOs from the master (CiA 301 §7.2.2, parameter objects §7.4.8): a node's TPDO and RPDO
//! parameters read by SDO into a typed [`PdoSet`], changed and saved back the CiA 301 way; and
//! the node's RPDOs transmitted by the master through the `canola-pdo` engine.
//!
//! * [`Node::tpdo`](crate::Node::tpdo) / [`Node::rpdo`](crate::Node::rpdo) → [`Tpdos`] / [`Rpdos`]. `read()` reads every PDO the node
//!   has (communication object 0x1800.. / 0x1400..: COB-ID, transmission type, inhibit time,
//!   event timer, SYNC start value; mapping object 0x1A00.. / 0x1600..) into one
//!   [`PdoParameters`] per PDO. `save()` writes the PDOs changed since they were read, each with
//!   the sequence [`Node::remap_pdo`] uses (invalidate the COB-ID, mapping count 0, entries,
//!   count, parameters, COB-ID as wanted).
//! * After a TPDO `read()` or `save()` the master decodes that TPDO from the COB-ID and with the
//!   mapping the node has (`NetworkEvent::PdoValues`), not only from the predefined ones.
//! * [`Rpdos::start`] transmits one of the node's RPDOs: the node's COB-ID and mapping, the
//!   master's [`Transmission`] (on change with an inhibit time, cyclic by event timer, or on the
//!   master's SYNC). The application sets mapped values through the [`RpdoSender`]; the
//!   network's own driving (background driver, waiting calls, `run_for`) sends the frames.
//!
//! * [`Node::mpdo`](crate::Node::mpdo) → [`Mpdos`]: the node's multiplexed PDOs (CiA 301 §7.2.3) received through
//!   the master's scanner list and delivered as PDOs, and DAM-MPDOs written with a [`DamSender`].
//!
//! Files by job: `params` (the parameters and their set), `handles` ([`Tpdos`], [`Rpdos`]),
//! `transmit` ([`Transmission`], [`RpdoSender`]), `mpdo` ([`Mpdos`], [`DamSender`]), `sequence` (the SDO sequences behind them).

mod handles;
mod mpdo;
mod params;
mod sequence;
mod transmit;

pub use handles::{Rpdos, Tpdos};
pub use mpdo::{DamSender, Mpdos};
pub use params::{MappedVariable, PdoParameters, PdoSet};
pub(crate) use sequence::remap;
pub use transmit::{RpdoSender, Transmission};
