//! Parse benchmark: this crate against python-canopen's `import_od`, as whole processes.
//!
//! ```text
//! cargo run --release -p canola-od --example parse_bench            # generate, run both, compare
//! cargo run --release -p canola-od --example parse_bench -- generate OUT.eds
//! cargo run --release -p canola-od --example parse_bench -- parse FILE   # one parse (child mode)
//! ```
//!
//! The benchmark file is generated deterministically: 2000 manufacturer objects (a VAR / ARRAY /
//! RECORD mix over every basic data type, `$NODEID` defaults on integer entries), about 2.7 MB.
//! Each side runs as a whole child process on the same file, twice per run: once on its own,
//! with the wall time measured around it, and once under `/usr/bin/time -f '%M %U %S'` for the
//! peak RSS in KiB and the user/system CPU time (the latter only to 10 ms). Each side runs
//! `BENCH_RUNS` times (default 5); the best wall and CPU times are compared (the machine may be
//! shared and noisy) and the medians printed too, with the
//! highest peak RSS. The entry counts of both sides must agree. Python is `$CANOPEN_PYTHON` or
//! `<workspace>/.venv/bin/python`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const TYPES: [(u16, &str); 25] = [
    (0x0001, "1"),
    (0x0002, "-0x12"),
    (0x0003, "-1234"),
    (0x0004, "-123456"),
    (0x0005, "0x7F"),
    (0x0006, "0x1234"),
    (0x0007, "0x12345678"),
    (0x0008, "1.5"),
    (0x0009, "Visible text"),
    (0x000A, "0102030405060708"),
    (0x000B, "Unicode text"),
    (0x000C, "0x123456789ABC"),
    (0x000D, "0x000100000064"),
    (0x000F, "DEADBEEF"),
    (0x0010, "-8000"),
    (0x0011, "-2.25e10"),
    (0x0012, "0x123456789A"),
    (0x0013, "-0x12345678"),
    (0x0014, "123456789012"),
    (0x0015, "-1234567890123"),
    (0x0016, "0xABCDEF"),
    (0x0018, "0x12345678AB"),
    (0x0019, "0x123456789ABC"),
    (0x001A, "0x123456789ABCDE"),
    (0x001B, "0x123456789ABCDEF0"),
];

fn is_integer(dt: u16) -> bool {
    matches!(dt, 0x02..=0x07 | 0x10 | 0x12..=0x16 | 0x18..=0x1B)
}

fn is_unsigned(dt: u16) -> bool {
    matches!(dt, 0x05..=0x07 | 0x16 | 0x18..=0x1B)
}

/// Deterministic pseudo-random numbers (xorshift), so the file is the same on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
}

fn entry(out: &mut String, rng: &mut Rng, name: &str, dt_pick: usize, node_relative: bool) {
    let (dt, default) = TYPES[dt_pick % TYPES.len()];
    let access = ["ro", "rw", "rww", "rwr", "const", "wo"][(rng.next() % 6) as usize];
    let pdo = u8::from(is_integer(dt) && rng.next().is_multiple_of(2));
    let _ = write!(
        out,
        "ParameterName={name}\r\nObjectType=0x7\r\nDataType=0x{dt:04X}\r\nAccessType={access}\r\n"
    );
    if node_relative && is_unsigned(dt) && dt != 0x05 {
        let _ = write!(
            out,
            "DefaultValue=$NODEID+0x{:X}\r\n",
            0x180 + rng.next() % 0x400
        );
    } else {
        let _ = write!(out, "DefaultValue={default}\r\n");
    }
    let _ = write!(out, "PDOMapping={pdo}\r\n");
    if is_unsigned(dt) && rng.next().is_multiple_of(3) {
        out.push_str("LowLimit=0x00\r\nHighLimit=0x7F\r\n");
    }
    out.push_str("\r\n");
}

/// The benchmark EDS: 2000 manufacturer objects plus the mandatory communication objects.
fn generate() -> String {
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    let mut s = String::with_capacity(3 << 20);
    s.push_str(
        "[FileInfo]\r\nFileName=bench.eds\r\nFileVersion=1\r\nFileRevision=0\r\nEDSVersion=4.0\r\n\
Description=Generated parse benchmark\r\nCreationTime=12:00PM\r\nCreationDate=01-01-2026\r\nCreatedBy=canola-od\r\n\
ModificationTime=12:00PM\r\nModificationDate=01-01-2026\r\nModifiedBy=canola-od\r\n\r\n\
[DeviceInfo]\r\nVendorName=Bench\r\nVendorNumber=0x12345678\r\nProductName=Bench device\r\nProductNumber=0x1\r\n\
RevisionNumber=0x1\r\nOrderCode=B-1\r\nBaudRate_10=1\r\nBaudRate_20=1\r\nBaudRate_50=1\r\nBaudRate_125=1\r\n\
BaudRate_250=1\r\nBaudRate_500=1\r\nBaudRate_800=0\r\nBaudRate_1000=1\r\nSimpleBootUpMaster=0\r\nSimpleBootUpSlave=1\r\n\
Granularity=8\r\nDynamicChannelsSupported=0\r\nGroupMessaging=0\r\nNrOfRXPDO=4\r\nNrOfTXPDO=4\r\nLSS_Supported=1\r\n\r\n\
[DummyUsage]\r\nDummy0001=0\r\nDummy0002=1\r\nDummy0003=1\r\nDummy0004=1\r\nDummy0005=1\r\nDummy0006=1\r\nDummy0007=1\r\n\r\n\
[Comments]\r\nLines=1\r\nLine1=Deterministic benchmark file\r\n\r\n\
[MandatoryObjects]\r\nSupportedObjects=3\r\n1=0x1000\r\n2=0x1001\r\n3=0x1018\r\n\r\n\
[1000]\r\nParameterName=Device type\r\nObjectType=0x7\r\nDataType=0x0007\r\nAccessType=ro\r\nDefaultValue=0x00000000\r\nPDOMapping=0\r\n\r\n\
[1001]\r\nParameterName=Error register\r\nObjectType=0x7\r\nDataType=0x0005\r\nAccessType=ro\r\nDefaultValue=0\r\nPDOMapping=1\r\n\r\n\
[1018]\r\nParameterName=Identity object\r\nObjectType=0x9\r\nSubNumber=2\r\n\r\n\
[1018sub0]\r\nParameterName=Highest sub-index supported\r\nObjectType=0x7\r\nDataType=0x0005\r\nAccessType=const\r\nDefaultValue=1\r\nPDOMapping=0\r\n\r\n\
[1018sub1]\r\nParameterName=Vendor-ID\r\nObjectType=0x7\r\nDataType=0x0007\r\nAccessType=ro\r\nDefaultValue=0x12345678\r\nPDOMapping=0\r\n\r\n\
[OptionalObjects]\r\nSupportedObjects=0\r\n\r\n",
    );
    let n = 2000u16;
    let _ = write!(s, "[ManufacturerObjects]\r\nSupportedObjects={n}\r\n");
    for i in 0..n {
        let _ = write!(s, "{}=0x{:04X}\r\n", i + 1, 0x2000 + i);
    }
    s.push_str("\r\n");
    for i in 0..n {
        let index = 0x2000 + i;
        let kind = rng.next() % 3;
        let dt_pick = (rng.next() % 25) as usize;
        match kind {
            0 => {
                let _ = write!(s, "[{index:04X}]\r\n");
                entry(
                    &mut s,
                    &mut rng,
                    &format!("Variable {i}"),
                    dt_pick,
                    i % 4 == 0,
                );
            }
            _ => {
                let subs = 9 + (rng.next() % 9) as u8;
                let code = if kind == 1 { 8 } else { 9 };
                let _ = write!(
                    s,
                    "[{index:04X}]\r\nParameterName={} {i}\r\nObjectType=0x{code}\r\nSubNumber=0x{:X}\r\n\r\n",
                    if code == 8 { "Array" } else { "Record" },
                    subs + 1
                );
                let _ = write!(
                    s,
                    "[{index:04X}sub0]\r\nParameterName=Highest sub-index supported\r\nObjectType=0x7\r\nDataType=0x0005\r\nAccessType=ro\r\nDefaultValue=0x{subs:02X}\r\nPDOMapping=0\r\n\r\n"
                );
                for sub in 1..=subs {
                    let _ = write!(s, "[{index:04X}sub{sub:X}]\r\n");
                    let pick = if code == 8 {
                        dt_pick
                    } else {
                        (rng.next() % 25) as usize
                    };
                    entry(
                        &mut s,
                        &mut rng,
                        &format!("Entry {i}.{sub}"),
                        pick,
                        sub % 3 == 0,
                    );
                }
            }
        }
    }
    s
}

fn workspace_root() -> PathBuf {
    let m = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    std::fs::canonicalize(&m).unwrap_or(m).join("../..")
}

/// Runs `program` twice: once directly, timed (wall seconds and its stdout), and once under
/// `/usr/bin/time` for peak RSS in KiB and CPU seconds (user + system). The wall time is taken
/// without the wrapper so that it holds the child's process alone, not the extra fork and
/// exec of `time` (about 1 ms here, an eighth of canola-od's whole run).
fn measure(program: &Path, args: &[&str]) -> (f64, u64, f64, String) {
    let start = Instant::now();
    let direct = Command::new(program)
        .args(args)
        .output()
        .expect("run the child");
    let wall = start.elapsed().as_secs_f64();
    assert!(
        direct.status.success(),
        "{} failed: {}",
        program.display(),
        String::from_utf8_lossy(&direct.stderr)
    );
    let out = Command::new("/usr/bin/time")
        .arg("-f")
        .arg("TIME %M %U %S")
        .arg(program)
        .args(args)
        .output()
        .expect("run /usr/bin/time");
    assert!(
        out.status.success(),
        "{} failed: {}",
        program.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    let fields: Vec<f64> = stderr
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("TIME "))
        .unwrap_or("")
        .split_whitespace()
        .filter_map(|f| f.parse().ok())
        .collect();
    let rss = fields.first().copied().unwrap_or(0.0) as u64;
    let cpu = fields.get(1).copied().unwrap_or(0.0) + fields.get(2).copied().unwrap_or(0.0);
    let stdout = String::from_utf8_lossy(&direct.stdout).trim().to_string();
    (wall, rss, cpu, stdout)
}

/// Results of a series of runs of one side.
struct Series {
    /// Best (lowest) and median wall time, seconds.
    wall: (f64, f64),
    /// Best and median CPU time (user + system), seconds.
    cpu: (f64, f64),
    /// Highest peak RSS over the runs, KiB.
    rss: u64,
    /// Best in-process time, seconds.
    inproc: f64,
    /// The entry count the child printed.
    entries: String,
}

/// Runs the child `runs` times: best and median wall and CPU time (the machine may be shared,
/// so the best run is the one least disturbed by other load), the highest peak RSS.
fn series(runs: usize, program: &Path, args: &[&str]) -> Series {
    let (mut wall, mut rss, mut cpu, mut inproc) = (Vec::new(), 0u64, Vec::new(), Vec::new());
    let mut entries = String::new();
    for _ in 0..runs {
        let (w, r, c, out) = measure(program, args);
        wall.push(w);
        rss = rss.max(r);
        cpu.push(c);
        let mut it = out.split_whitespace();
        entries = it.next().unwrap_or("").to_string();
        inproc.push(it.next().and_then(|t| t.parse().ok()).unwrap_or(0.0));
    }
    let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    Series {
        wall: (best(&wall), median(wall)),
        cpu: (best(&cpu), median(cpu)),
        rss,
        inproc: best(&inproc),
        entries,
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("generate") => {
            let out = args.get(1).expect("generate OUT");
            std::fs::write(out, generate()).expect("write");
            return;
        }
        Some("parse") => {
            let path = args.get(1).expect("parse FILE");
            let start = Instant::now();
            let bytes = std::fs::read(path).expect("read");
            let p = canola_od::parse(&bytes).expect("bench file parses");
            let entries = p.od.entries().count();
            println!("{entries} {:.6}", start.elapsed().as_secs_f64());
            // The process ends here: let the OS reclaim the model instead of freeing its
            // allocations one by one (what a command-line tool would do too).
            std::mem::forget(p);
            return;
        }
        _ => {}
    }

    let dir = std::env::temp_dir().join("canopen-od-bench");
    std::fs::create_dir_all(&dir).expect("temp dir");
    let file = dir.join("bench_2000.eds");
    let text = generate();
    std::fs::write(&file, &text).expect("write bench file");
    let file_s = file.to_str().expect("utf-8 path");
    println!(
        "benchmark file: {} ({} bytes, {} lines)",
        file.display(),
        text.len(),
        text.lines().count()
    );

    let me = std::env::current_exe().expect("current exe");
    let python = std::env::var_os("CANOPEN_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join(".venv/bin/python"));
    let py_code = "import sys, time\nt = time.perf_counter()\nimport canopen\nod = canopen.import_od(sys.argv[1])\n\
n = sum(len(o) if hasattr(o, 'subindices') else 1 for o in od.values())\nprint(n, round(time.perf_counter() - t, 6))";

    let runs = std::env::var("BENCH_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    let r = series(runs, &me, &["parse", file_s]);
    let p = series(runs, &python, &["-c", py_code, file_s]);
    // Both sides must have read the same dictionary. python-canopen also adds one object per
    // `DummyNNNN=1` of [DummyUsage] (the file enables six); canola-od keeps those as flags.
    let dummies = 6;
    assert_eq!(
        r.entries.parse::<usize>().ok().map(|n| n + dummies),
        p.entries.parse::<usize>().ok(),
        "entry counts differ"
    );
    for (who, s) in [("canola-od    ", &r), ("python-canopen", &p)] {
        println!(
            "{who} : entries {:>6}, wall best {:8.1} ms (median {:8.1}), CPU best {:7.1} ms (median {:7.1}), in-process best {:7.1} ms, peak RSS {:>7} KiB",
            s.entries,
            s.wall.0 * 1e3,
            s.wall.1 * 1e3,
            s.cpu.0 * 1e3,
            s.cpu.1 * 1e3,
            s.inproc * 1e3,
            s.rss
        );
    }
    println!(
        "ratio python-canopen / canola-od (best of {runs} each): wall time {:.0}x, peak RSS {:.1}x, CPU time {:.0}x (medians: wall {:.0}x, CPU {:.0}x; CPU times are in 10 ms steps, coarse for canola-od: use `perf stat -e task-clock` for a precise figure)",
        p.wall.0 / r.wall.0,
        p.rss as f64 / r.rss.max(1) as f64,
        p.cpu.0 / r.cpu.0.max(0.005),
        p.wall.1 / r.wall.1,
        p.cpu.1 / r.cpu.1.max(0.005),
    );
}
