//! Generates typed Rust for the Bürkert generic profile into `OUT_DIR`, the way an application
//! would for its devices: entries, one struct per default PDO mapping, and the typed node client
//! on the `canola` facade (`Config::for_canola`).

fn main() {
    if let Err(e) = canola_codegen::Config::for_canola().compile("../../eds/burkert-generic.eds") {
        panic!("{e}");
    }
}
