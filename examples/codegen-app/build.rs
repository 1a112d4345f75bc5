//! Generates typed Rust for the Bürkert generic profile into `OUT_DIR`, the way an application
//! would for its devices: entries, one struct per default PDO mapping, and the typed node client
//! on the `canopen` facade (`Config::for_canopen`).

fn main() {
    if let Err(e) = canopen_codegen::Config::for_canopen().compile("../../eds/burkert-generic.eds")
    {
        panic!("{e}");
    }
}
