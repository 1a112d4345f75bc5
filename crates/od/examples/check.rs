//! Parses EDS/DCF files and prints the diagnostics (a development aid).
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut failed = false;
    for path in std::env::args().skip(1) {
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{path}: {e}");
                failed = true;
                continue;
            }
        };
        match canopen_od::parse(&bytes) {
            Ok(p) => {
                for d in &p.diagnostics {
                    eprintln!("{}", d.render(&path));
                }
                println!(
                    "{path}: ok, {} objects, {} warnings",
                    p.od.objects.len(),
                    p.diagnostics.len()
                );
            }
            Err(e) => {
                for d in &e.diagnostics {
                    eprintln!("{}", d.render(&path));
                }
                println!("{path}: FAILED");
                failed = true;
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
