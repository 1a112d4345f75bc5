//! The code generated from `eds/burkert-generic.eds` in `build.rs`, as an application's crate
//! holds it: one `include!` per device.

/// The Bürkert generic profile: entry constants, `Tpdo1`.. / `Rpdo1`.. structs and
/// `client::Device`.
pub mod burkert {
    include!(concat!(env!("OUT_DIR"), "/burkert-generic.rs"));
}
