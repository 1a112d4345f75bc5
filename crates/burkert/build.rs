//! Generates the typed entries of the Bürkert profile from eds/burkert-generic.eds with the
//! project's own code generator.

use canola_codegen::{Config, StringTypes};

fn main() {
    let result = Config::new()
        // Without an allocator, string and DOMAIN entries are opaque (index and type only).
        .strings(StringTypes::Feature("alloc".into()))
        .static_dictionary(true)
        .compile("burkert-generic.eds");
    if let Err(e) = result {
        eprintln!("canola-burkert: cannot generate entries: {e}");
        std::process::exit(1);
    }
}
