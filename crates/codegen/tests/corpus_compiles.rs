//! Generated code from every file of the EDS corpus (../shared/eds-corpus, beside the checkout)
//! compiles: the test writes scratch crates with one module per file and runs `cargo check` on
//! them: a `no_std` one with the entries, the static dictionary and the PDO structs, and one on
//! the `canola` facade with the PDO structs and the typed client ([`Config::for_canola`]).
//! Skips with a message when the corpus is absent, unless CANOPEN_REQUIRE_CORPUS=1.

use std::path::{Path, PathBuf};
use std::process::Command;

use canola_codegen::Config;

fn corpus_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/eds-corpus");
    dir.is_dir().then_some(dir)
}

#[test]
fn every_corpus_file_generates_code_that_compiles() {
    let Some(dir) = corpus_dir() else {
        assert!(
            std::env::var_os("CANOPEN_REQUIRE_CORPUS").is_none(),
            "CANOPEN_REQUIRE_CORPUS=1 but ../shared/eds-corpus is missing"
        );
        eprintln!("SKIPPED: ../shared/eds-corpus not found beside the checkout");
        return;
    };
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap();
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join("target"));
    let scratch = target.join("codegen-corpus-check");
    let facade = target.join("codegen-corpus-facade");
    std::fs::create_dir_all(scratch.join("src")).unwrap();
    std::fs::create_dir_all(facade.join("src")).unwrap();

    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("eds") || e.eq_ignore_ascii_case("dcf"))
        })
        .collect();
    files.sort();
    let mut lib = String::from(
        "//! Scratch crate: generated code of every corpus file.\n#![no_std]\n#![allow(missing_docs)]\nextern crate alloc;\n",
    );
    let mut facade_lib =
        String::from("//! Scratch crate: corpus files on the facade.\n#![allow(missing_docs)]\n");
    let mut generated = 0;
    let (mut structs, mut with_structs, mut notes_total) = (0, 0, 0);
    for (i, path) in files.iter().enumerate() {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let bytes = std::fs::read(path).unwrap();
        let Ok(parsed) = canola_od::parse(&bytes) else {
            // kaco__401.eds is broken on purpose; the od crate's corpus test checks its errors.
            assert_eq!(name, "kaco__401.eds", "{name} must parse");
            continue;
        };
        let code = Config::new()
            .static_dictionary(true)
            .pdo_structs(true)
            .generate(&parsed.od, &name);
        let (facade_code, notes) = Config::for_canola().generate_with_notes(&parsed.od, &name);
        for note in &notes {
            eprintln!("{name}: {note}");
        }
        notes_total += notes.len();
        let n = code.matches("\npub struct ").count();
        structs += n;
        with_structs += usize::from(n > 0);
        for line in code.lines().chain(facade_code.lines()) {
            assert!(
                !line.contains("pub const _") && !line.contains("pub mod _"),
                "{name}: a generated name starts with an underscore: {line}"
            );
        }
        std::fs::write(scratch.join(format!("src/m{i}.rs")), code).unwrap();
        std::fs::write(facade.join(format!("src/m{i}.rs")), facade_code).unwrap();
        facade_lib.push_str(&format!(
            "/// {name}\npub mod m{i} {{ include!(\"m{i}.rs\"); }}\n"
        ));
        lib.push_str(&format!(
            "/// {name}\npub mod m{i} {{ include!(\"m{i}.rs\"); }}\n"
        ));
        generated += 1;
    }
    std::fs::write(scratch.join("src/lib.rs"), lib).unwrap();
    std::fs::write(
        scratch.join("Cargo.toml"),
        format!(
            "[package]\nname = \"codegen-corpus-check\"\nversion = \"0.0.0\"\nedition = \"2024\"\npublish = false\n\n[workspace]\n\n[dependencies]\ncanola-od = {{ path = {:?}, default-features = false, features = [\"alloc\"] }}\ncanola-pdo = {{ path = {:?}, default-features = false }}\n",
            workspace.join("crates/od").display().to_string(),
            workspace.join("crates/pdo").display().to_string()
        ),
    )
    .unwrap();
    std::fs::write(facade.join("src/lib.rs"), facade_lib).unwrap();
    std::fs::write(
        facade.join("Cargo.toml"),
        format!(
            "[package]\nname = \"codegen-corpus-facade\"\nversion = \"0.0.0\"\nedition = \"2024\"\npublish = false\n\n[workspace]\n\n[dependencies]\ncanola = {{ path = {:?} }}\n",
            workspace.join("crates/canola").display().to_string()
        ),
    )
    .unwrap();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    for krate in [&scratch, &facade] {
        let out = Command::new(&cargo)
            .args(["check", "--quiet", "--offline", "--manifest-path"])
            .arg(krate.join("Cargo.toml"))
            .env("CARGO_TARGET_DIR", target.join("codegen-corpus-target"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "generated code of the corpus does not compile ({}):\n{}",
            krate.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            !stderr.contains("warning"),
            "generated code of the corpus has warnings ({}):\n{stderr}",
            krate.display()
        );
    }
    assert_eq!(
        generated,
        files.len() - 1,
        "every corpus file but kaco__401.eds generates code"
    );
    eprintln!(
        "generated and compiled code for {generated} corpus files; {structs} PDO structs from {with_structs} of them; {notes_total} default mappings left out with a note"
    );
    assert!(
        with_structs * 2 > generated,
        "most corpus files have default PDO mappings: {with_structs} of {generated}"
    );
}
