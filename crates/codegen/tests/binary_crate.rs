//! Generated code in the place users put it: a scratch binary crate whose `build.rs` calls
//! `compile_eds` for the Bürkert profile (hundreds of entries, nearly all unused by the binary)
//! and for a small EDS with warnings and names that start with digits, and with the facade
//! preset (PDO structs and the typed client) for the PDO test device. `cargo build` must succeed
//! with no warning but the EDS's own, which the build script passes to cargo.

use std::path::{Path, PathBuf};
use std::process::Command;

const QUIRKY: &str = "[FileInfo]\nEDSVersion=4.0\n\
[1600]\nParameterName=RPDO1 mapping\nObjectType=0x9\nSubNumber=2\n\
[1600sub0]\nParameterName=Number of mapped objects\nDataType=0x0005\nAccessType=rw\nDefaultValue=1\n\
[1600sub1]\nParameterName=1st mapped object in RxPDO 1\nDataType=0x0007\nAccessType=rw\nDefaultValue=0x20000108\n\
[2000]\nparametername=24V supply\nDataType=0x0006\nAccessType=ro\nDefaultValue=24LL\n";

#[test]
fn a_binary_crate_builds_without_warnings_and_sees_the_eds_warnings() {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap();
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join("target"));
    let scratch = target.join("codegen-binary-check");
    std::fs::create_dir_all(scratch.join("src")).unwrap();
    let path = |rel: &str| workspace.join(rel).display().to_string();
    std::fs::write(
        scratch.join("Cargo.toml"),
        format!(
            "[package]\nname = \"codegen-binary-check\"\nversion = \"0.0.0\"\nedition = \"2024\"\npublish = false\n\n[workspace]\n\n\
             [dependencies]\ncanola-od = {{ path = {:?} }}\ncanola = {{ path = {:?} }}\n\n[build-dependencies]\ncanola-codegen = {{ path = {:?} }}\n",
            path("crates/od"),
            path("crates/canola"),
            path("crates/codegen"),
        ),
    )
    .unwrap();
    // A fresh comment each run, so that the build script runs again and its warnings show.
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos();
    std::fs::write(
        scratch.join("quirky.eds"),
        format!("; run {stamp}\n{QUIRKY}"),
    )
    .unwrap();
    std::fs::write(
        scratch.join("build.rs"),
        format!(
            "fn main() {{\n    canola_codegen::compile_eds({:?}).unwrap();\n    canola_codegen::compile_eds(\"quirky.eds\").unwrap();\n    canola_codegen::Config::for_canola().compile({:?}).unwrap();\n}}\n",
            path("eds/burkert-generic.eds"),
            path("crates/codegen/tests/data/pdo-device.eds")
        ),
    )
    .unwrap();
    std::fs::write(
        scratch.join("src/main.rs"),
        "mod burkert {\n    include!(concat!(env!(\"OUT_DIR\"), \"/burkert-generic.rs\"));\n}\n\
         mod quirky {\n    include!(concat!(env!(\"OUT_DIR\"), \"/quirky.rs\"));\n}\n\
         mod device {\n    include!(concat!(env!(\"OUT_DIR\"), \"/pdo-device.rs\"));\n}\n\n\
         fn main() {\n    println!(\"{:?}\", device::Tpdo1::from_data(&[0; 6]));\n    println!(\"{} {}\", burkert::PRODUCER_HEARTBEAT_TIME, quirky::rpdo1_mapping::FIRST_MAPPED_OBJECT_IN_RX_PDO_1);\n    println!(\"{}\", quirky::OBJ_24V_SUPPLY);\n}\n",
    )
    .unwrap();

    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["build", "--offline", "--manifest-path"])
        .arg(scratch.join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", target.join("codegen-corpus-target"))
        .env_remove("RUSTFLAGS")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "the binary crate does not build:\n{stderr}"
    );
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.trim_start().starts_with("warning"))
        .collect();
    // The EDS's warnings come through cargo, each as FILE:LINE: warning: ...
    let eds_warnings: Vec<&&str> = warnings
        .iter()
        .filter(|l| l.contains("codegen-binary-check@0.0.0: quirky.eds:"))
        .collect();
    assert!(
        eds_warnings
            .iter()
            .any(|l| l.contains("quirky.eds:") && l.contains("C integer suffix")),
        "{stderr}"
    );
    assert!(
        eds_warnings.iter().any(|l| l.contains("`parametername`")),
        "{stderr}"
    );
    // The generator's own note on the PDO test device's TPDO4, whose default mapping is invalid.
    let note =
        "pdo-device.eds: codegen: no struct Tpdo4: the default mapping at 0x1A03 is not valid";
    assert!(warnings.iter().any(|l| l.contains(note)), "{stderr}");
    let others: Vec<&&str> = warnings
        .iter()
        .filter(|l| !l.contains("codegen-binary-check@0.0.0: quirky.eds:") && !l.contains(note))
        .collect();
    assert!(others.is_empty(), "warnings besides the EDS's:\n{stderr}");

    let generated = std::fs::read_dir(target.join("codegen-corpus-target/debug/build"))
        .unwrap()
        .filter_map(|e| {
            let p = e.ok()?.path().join("out/quirky.rs");
            let modified = p.metadata().ok()?.modified().ok()?;
            Some((modified, p))
        })
        .max()
        .map(|(_, p)| std::fs::read_to_string(p).unwrap())
        .expect("quirky.rs was generated");
    for line in generated.lines() {
        assert!(
            !line.contains("pub const _") && !line.contains("pub mod _"),
            "a generated name starts with an underscore: {line}"
        );
    }
}
