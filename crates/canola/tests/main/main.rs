//! The facade's integration tests, built as one test binary: each module is one subject (its
//! module doc says which). One binary links the library and its dependencies once instead of
//! once per subject. No test here needs a process of its own: the interop tests that bind UDP
//! ports derive them from the process id with an offset of their own, so they do not meet.

#[cfg(feature = "tokio")]
mod asynch;
mod clock_reading;
mod driver;
mod faults;
mod fd_pdo;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
mod fd_python;
mod flaky_transport;
mod join;
mod mpdo;
mod network;
mod nmt_state;
mod no_data_loss;
#[cfg(feature = "tokio")]
mod operation;
mod pdo;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
mod pdo_python;
mod real_devices;
mod restricted_cob_ids;
mod run_step;
mod sim_warnings;
#[cfg(all(unix, feature = "slcan"))]
mod slcan_transport;
mod store_restore;
mod typed;
mod typed_values;
mod usdo;
