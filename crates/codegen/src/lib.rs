//! Typed Rust from CiA 306 EDS/DCF files, the way `prost-build` turns `.proto` files into Rust.
//!
//! Every sub-object becomes a typed [`canola_od::Entry`] constant that carries its index,
//! sub-index and the Rust type of its value, so the producer heartbeat time is an
//! `Entry<u16>` at 0x1017:00 and a master reads it as a `u16`. VAR objects become constants at the
//! top level; ARRAY and RECORD objects become modules holding an `INDEX` and one constant per
//! sub-object. Names come from ParameterName (sanitised, keywords avoided, collisions resolved by
//! appending the index or sub-index; a leading ordinal is spelled out, `1st mapped object` →
//! `FIRST_MAPPED_OBJECT`, and no name starts with an underscore); doc comments carry what the EDS
//! says of each entry. Optionally a static, allocation-free dictionary of the whole device is
//! emitted as well. Every generated item is `#[allow(dead_code)]`, so a binary crate that uses
//! a few entries of a large device builds without warnings.
//!
//! In `build.rs`:
//!
//! ```no_run
//! // build.rs, in `fn main`: on error, FILE:LINE: error: ... for each error of the EDS
//! if let Err(e) = canola_codegen::compile_eds("eds/my-device.eds") {
//!     panic!("{e}");
//! }
//! ```
//!
//! and in the crate: `include!(concat!(env!("OUT_DIR"), "/my-device.rs"));`. The output starts
//! with an `@generated` header, is only rewritten when its content changes, and the EDS is
//! reported with `cargo:rerun-if-changed`; its warnings are passed to cargo as
//! `cargo:warning=FILE:LINE: warning: ...` (see [`Config::style_warnings`] for the form-only ones).
//!
//! A master then reads and writes the entries with their Rust types, through the `canola`
//! facade's SDO client:
//!
//! ```ignore
//! include!(concat!(env!("OUT_DIR"), "/my-device.rs"));
//!
//! let node = network.node(node_id);
//! let vendor: u32 = node.sdo().read_entry(&identity::VENDOR_ID).wait()?;
//! node.sdo().write_entry(&PRODUCER_HEARTBEAT_TIME, &1000).wait()?;
//! ```
//!
//! # PDO structs and the typed client
//!
//! [`Config::pdo_structs`] adds one struct per PDO the file maps by default (`Rpdo1` for
//! 0x1600, `Tpdo1` for 0x1A00, ...) with a named field of the mapped object's Rust type per
//! entry; dummy entries take their bits and no field, and 1-bit BOOLEANs or fields that do not
//! start on a byte are packed and unpacked by `canola-pdo` (the structs implement
//! `canola_pdo::TypedPdo`; the generated code holds no bit arithmetic). The default COB-ID
//! keeps `$NODEID` as "add the node-ID", resolved when the node is known. Mappings the file
//! leaves empty give no struct; an invalid one gives none and a note ([`Config::compile`] passes
//! notes to cargo as warnings). [`Config::client`] adds `client::Device`, one method per object
//! over the `canola` facade. [`Config::for_canola`] turns both on with paths into the
//! facade, so an application needs only `canola`:
//!
//! ```ignore
//! // build.rs
//! canola_codegen::Config::for_canola().compile("eds/my-device.eds").unwrap();
//!
//! // the application
//! include!(concat!(env!("OUT_DIR"), "/my-device.rs"));
//! let dev = client::Device::new(network.node(node_id));
//! dev.producer_heartbeat_time().write(200)?; // UNSIGNED16: `200` is a u16
//! let serial: u32 = dev.identity_object().serial_number().read()?;
//! let tpdo1 = Tpdo1::from_frame(&frame)?; // one call, typed fields
//! assert_eq!(Tpdo1::cob_id(node_id).map(|c| c.0), Some(0x180 + u32::from(node_id.get())));
//! network.send(Rpdo1 { setpoint: 42, ..Default::default() }.to_frame(node_id)?)?;
//! ```
//!
//! The workspace's `examples/codegen-app` is such an application, run on the in-memory bus.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use canola_od::{
    DataType, Diagnostic, Object, ObjectCode, ObjectDictionary, ParseOptions, SubObject,
};

mod client;
mod names;
mod pdo;

/// How entries of string and byte-string data types are typed.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum StringTypes {
    /// `OwnedString` / `OwnedBytes` (needs `canola-od`'s `alloc` feature).
    #[default]
    Owned,
    /// [`canola_od::entry::Opaque`]: no allocator needed.
    Opaque,
    /// Owned when the *generated-into* crate's feature of this name is on, opaque otherwise.
    Feature(String),
}

/// Generator settings, builder style.
#[derive(Debug, Clone)]
pub struct Config {
    crate_path: String,
    strings: StringTypes,
    static_dictionary: bool,
    out_dir: Option<PathBuf>,
    file_name: Option<String>,
    style_warnings: bool,
    pdo_crate_path: String,
    facade_path: String,
    pdo_structs: bool,
    client: bool,
}

/// What can go wrong generating code from a file.
///
/// `Debug` prints the same text as `Display`, so that `compile_eds(..).unwrap()` in a build
/// script shows the EDS errors line by line rather than an escaped string.
#[derive(thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading the EDS or writing the output failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The EDS has errors. The message lists them one per line as `FILE:LINE: error: ...`.
    #[error("{}", render_errors(file, error))]
    Parse {
        /// The file, as the messages name it.
        file: String,
        /// The parser's diagnostics (the errors, and the warnings beside them).
        error: canola_od::ParseError,
    },
    /// No output directory: neither set nor `OUT_DIR` in the environment.
    #[error("no output directory: call Config::out_dir or run from a build script (OUT_DIR)")]
    NoOutDir,
}

impl std::fmt::Debug for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::new()
    }
}

impl Config {
    /// Defaults: entries refer to `::canola_od`, owned strings, no static dictionary, output into
    /// `OUT_DIR` as `<eds file stem>.rs`.
    pub fn new() -> Self {
        Self {
            crate_path: "::canola_od".to_owned(),
            strings: StringTypes::Owned,
            static_dictionary: false,
            out_dir: None,
            file_name: None,
            style_warnings: true,
            pdo_crate_path: "::canola_pdo".to_owned(),
            facade_path: "::canola".to_owned(),
            pdo_structs: false,
            client: false,
        }
    }

    /// The preset for an application on the `canola` facade, which then needs no other
    /// dependency than `canola`: entries through `::canola::od`, PDO structs through
    /// `::canola::pdo` ([`Config::pdo_structs`]) and the typed node client
    /// ([`Config::client`]).
    pub fn for_canola() -> Self {
        let mut c = Self::new();
        c.crate_path("::canola::od")
            .pdo_crate_path("::canola::pdo")
            .facade_path("::canola")
            .pdo_structs(true)
            .client(true);
        c
    }

    /// Also emit one struct per PDO the file maps by default (`Tpdo1` for mapping 0x1A00,
    /// `Rpdo1` for 0x1600, ...): named fields of the mapped objects' Rust types, implementing
    /// `canola_pdo::TypedPdo`, so `Tpdo1::from_frame(&frame)` decodes a received PDO and
    /// `to_frame(node)` builds one. Mappings the file leaves empty give no struct; one that is
    /// not valid gives none either, with a warning (see [`Config::generate_with_notes`]). The
    /// generated code then needs `canola-pdo` (no allocator needed). Off by default.
    pub fn pdo_structs(&mut self, on: bool) -> &mut Self {
        self.pdo_structs = on;
        self
    }

    /// The path generated PDO structs use for the `canola-pdo` crate (default
    /// `::canola_pdo`).
    pub fn pdo_crate_path(&mut self, path: impl Into<String>) -> &mut Self {
        self.pdo_crate_path = path.into();
        self
    }

    /// Also emit `client::Device`, a typed client of one node over the `canola` facade: one
    /// method per object, returning a handle whose `read()` and `write(value)` go through
    /// `Sdo::read_entry` / `Sdo::write_entry`, e.g. `dev.producer_heartbeat_time().write(200)`.
    /// Read-only objects have no `write`, write-only ones no `read`. ARRAY and RECORD objects
    /// give a method returning their module's `Client` with one method per sub-object. Needs the
    /// `canola` crate (std). Off by default.
    pub fn client(&mut self, on: bool) -> &mut Self {
        self.client = on;
        self
    }

    /// The path the client uses for the `canola` facade crate (default `::canola`).
    pub fn facade_path(&mut self, path: impl Into<String>) -> &mut Self {
        self.facade_path = path.into();
        self
    }

    /// Whether [`Config::compile`] passes the EDS's form-only warnings (key case, lower-case hex,
    /// trailing blanks: [`canola_od::DiagnosticKind::Style`]) to cargo. On by default.
    pub fn style_warnings(&mut self, on: bool) -> &mut Self {
        self.style_warnings = on;
        self
    }

    /// The path generated code uses for the `canola-od` crate (for crates that re-export it).
    pub fn crate_path(&mut self, path: impl Into<String>) -> &mut Self {
        self.crate_path = path.into();
        self
    }

    /// How string and DOMAIN entries are typed.
    pub fn strings(&mut self, strings: StringTypes) -> &mut Self {
        self.strings = strings;
        self
    }

    /// Also emit `DICTIONARY`: every sub-object with metadata and default bytes, allocation-free.
    pub fn static_dictionary(&mut self, yes: bool) -> &mut Self {
        self.static_dictionary = yes;
        self
    }

    /// Where [`Config::compile`] writes (default: `OUT_DIR`).
    pub fn out_dir(&mut self, dir: impl Into<PathBuf>) -> &mut Self {
        self.out_dir = Some(dir.into());
        self
    }

    /// The output file name (default: the EDS file stem with `.rs`).
    pub fn file_name(&mut self, name: impl Into<String>) -> &mut Self {
        self.file_name = Some(name.into());
        self
    }

    /// Generates Rust source for a dictionary. `source_name` names the input in the header.
    pub fn generate(&self, od: &ObjectDictionary, source_name: &str) -> String {
        self.generate_with_notes(od, source_name).0
    }

    /// Generates Rust source and says what of the file it left out and why (a default PDO
    /// mapping that is not valid, say), one line per note. [`Config::compile`] passes the notes
    /// to cargo as warnings.
    pub fn generate_with_notes(
        &self,
        od: &ObjectDictionary,
        source_name: &str,
    ) -> (String, Vec<String>) {
        let mut generator = Generator {
            cfg: self,
            out: String::new(),
            notes: Vec::new(),
            client_items: Vec::new(),
        };
        generator.run(od, source_name);
        (generator.out, generator.notes)
    }

    /// Reads and parses `eds`, generates code and writes it into the output directory, only
    /// if the content changed. Prints `cargo:rerun-if-changed` for the EDS and one
    /// `cargo:warning=FILE:LINE: warning: ...` per warning of the parser, which cargo shows (for
    /// path and workspace dependencies). Returns the path of the generated file.
    pub fn compile(&self, eds: impl AsRef<Path>) -> Result<PathBuf, Error> {
        let eds = eds.as_ref();
        println!("cargo:rerun-if-changed={}", eds.display());
        let bytes = std::fs::read(eds).map_err(|source| Error::Io {
            path: eds.to_owned(),
            source,
        })?;
        let display = eds.display().to_string();
        let options = ParseOptions::new().style_warnings(self.style_warnings);
        let (od, warnings) = parse(&bytes, &display, options)?;
        for w in &warnings {
            println!("cargo:warning={}", w.render(&display));
        }
        let dir = match &self.out_dir {
            Some(d) => d.clone(),
            None => std::env::var_os("OUT_DIR")
                .map(PathBuf::from)
                .ok_or(Error::NoOutDir)?,
        };
        let name = match &self.file_name {
            Some(n) => n.clone(),
            None => {
                let stem = eds.file_stem().map(|s| s.to_string_lossy().into_owned());
                format!("{}.rs", stem.unwrap_or_else(|| "dictionary".to_owned()))
            }
        };
        let source_name = eds
            .file_name()
            .map_or(display.clone(), |n| n.to_string_lossy().into_owned());
        let (code, notes) = self.generate_with_notes(&od, &source_name);
        for note in &notes {
            println!("cargo:warning={display}: codegen: {note}");
        }
        let path = dir.join(name);
        write_if_changed(&path, &code)?;
        Ok(path)
    }
}

/// One call for `build.rs`: [`Config::new`] and [`Config::compile`].
pub fn compile_eds(eds: impl AsRef<Path>) -> Result<PathBuf, Error> {
    Config::new().compile(eds)
}

fn parse(
    bytes: &[u8],
    file: &str,
    options: ParseOptions,
) -> Result<(ObjectDictionary, Vec<Diagnostic>), Error> {
    match canola_od::parse_with(bytes, options) {
        Ok(parsed) => Ok((parsed.od, parsed.diagnostics)),
        Err(error) => Err(Error::Parse {
            file: file.to_owned(),
            error,
        }),
    }
}

/// The errors of a file that did not parse, one per line.
fn render_errors(file: &str, error: &canola_od::ParseError) -> String {
    let mut msg = String::new();
    for d in error.errors() {
        let _ = writeln!(msg, "{}", d.render(file));
    }
    msg.truncate(msg.trim_end().len());
    msg
}

fn write_if_changed(path: &Path, code: &str) -> Result<(), Error> {
    if std::fs::read_to_string(path).is_ok_and(|old| old == code) {
        return Ok(());
    }
    std::fs::write(path, code).map_err(|source| Error::Io {
        path: path.to_owned(),
        source,
    })
}

struct Generator<'a> {
    cfg: &'a Config,
    out: String,
    /// What was left out and why.
    notes: Vec<String>,
    /// The objects the client gets a method for, in dictionary order.
    client_items: Vec<client::Item>,
}

/// The Rust type of an entry's value: (always, with alloc, without alloc).
enum RustType {
    Plain(&'static str),
    Alloc { owned: &'static str },
    Opaque,
}

fn rust_type(dt: DataType) -> RustType {
    use DataType::*;
    RustType::Plain(match dt {
        Boolean => "bool",
        Integer8 => "i8",
        Integer16 => "i16",
        Integer24 | Integer32 => "i32",
        Integer40 | Integer48 | Integer56 | Integer64 => "i64",
        Unsigned8 => "u8",
        Unsigned16 => "u16",
        Unsigned24 | Unsigned32 => "u32",
        Unsigned40 | Unsigned48 | Unsigned56 | Unsigned64 => "u64",
        Real32 => "f32",
        Real64 => "f64",
        TimeOfDay | TimeDifference => "[u8; 6]",
        VisibleString | UnicodeString => {
            return RustType::Alloc {
                owned: "OwnedString",
            };
        }
        OctetString | Domain => {
            return RustType::Alloc {
                owned: "OwnedBytes",
            };
        }
        _ => return RustType::Opaque,
    })
}

fn variant(dt: DataType) -> String {
    match dt {
        DataType::Other(code) => format!("Other({code:#06x})"),
        other => format!("{other:?}"),
    }
}

/// A doc comment line: one line of text, no control characters, and square brackets escaped so
/// rustdoc does not take EDS names such as `Operation Time_[s]` for intra-doc links.
fn doc_line(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.trim().chars() {
        match c {
            '[' | ']' => {
                out.push('\\');
                out.push(c);
            }
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

impl Generator<'_> {
    fn run(&mut self, od: &ObjectDictionary, source_name: &str) {
        let _ = writeln!(
            self.out,
            "// @generated by canola-codegen {} from `{}`. Do not edit.",
            env!("CARGO_PKG_VERSION"),
            doc_line(source_name)
        );
        let vendor = od.device_info.vendor_name.as_deref().unwrap_or("");
        let product = od.device_info.product_name.as_deref().unwrap_or("");
        if !vendor.is_empty() || !product.is_empty() {
            let _ = writeln!(
                self.out,
                "// Device: {} {}",
                doc_line(vendor),
                doc_line(product)
            );
        }
        self.out.push('\n');

        let mut consts = names::Scope::default();
        let mut mods = names::Scope::default();
        consts.reserve("DICTIONARY");
        if self.cfg.client {
            mods.reserve("client");
        }
        for obj in od.objects.values() {
            // DEFTYPE / DEFSTRUCT entries define data types, not values.
            if matches!(obj.object_code, ObjectCode::DefType | ObjectCode::DefStruct) {
                continue;
            }
            if obj.is_simple() {
                if let Some(sub) = obj.var_entry() {
                    let name = consts.unique(
                        names::screaming(&obj.name, &format!("obj_{:04x}", obj.index)),
                        &format!("{:04X}", obj.index),
                    );
                    self.entry(obj, sub, &name, "");
                    if let Some(item) = client::Item::var(self.cfg, obj, sub, &name) {
                        self.client_items.push(item);
                    }
                }
            } else {
                let name = mods.unique(
                    names::snake(&obj.name, &format!("obj_{:04x}", obj.index)),
                    &format!("{:04x}", obj.index),
                );
                self.record(obj, &name);
            }
        }
        if self.cfg.static_dictionary {
            self.dictionary(od);
        }
        if self.cfg.pdo_structs {
            self.pdos(od);
        }
        if self.cfg.client {
            self.client(od);
        }
    }

    fn record(&mut self, obj: &Object, module: &str) {
        let _ = writeln!(self.out, "/// {}", doc_line(&obj.name));
        let _ = writeln!(self.out, "///");
        let _ = writeln!(
            self.out,
            "/// Object `{:#06X}`, {:?} with {} sub-objects.",
            obj.index,
            obj.object_code,
            obj.subs.len()
        );
        let _ = writeln!(self.out, "#[allow(dead_code)]");
        let _ = writeln!(self.out, "pub mod {module} {{");
        let _ = writeln!(self.out, "    /// The object index, `{:#06X}`.", obj.index);
        let _ = writeln!(self.out, "    pub const INDEX: u16 = {:#06X};", obj.index);
        let mut scope = names::Scope::default();
        scope.reserve("INDEX");
        let mut subs = Vec::new();
        for sub in obj.subs.values() {
            let name = scope.unique(
                names::screaming(&sub.name, &format!("sub_{}", sub.sub_index)),
                &sub.sub_index.to_string(),
            );
            self.entry(obj, sub, &name, "    ");
            subs.extend(client::Item::var(self.cfg, obj, sub, &name));
        }
        if self.cfg.client {
            self.record_client(obj, &subs);
            self.client_items.push(client::Item::record(obj, module));
        }
        let _ = writeln!(self.out, "}}\n");
    }

    fn entry(&mut self, obj: &Object, sub: &SubObject, name: &str, indent: &str) {
        let krate = &self.cfg.crate_path;
        let mut facts = format!(
            "`{:#06X}` sub {}: {}, {}",
            obj.index,
            sub.sub_index,
            sub.data_type.name().map_or_else(
                || format!("data type {:#06x}", sub.data_type.code()),
                str::to_owned
            ),
            sub.access
        );
        if sub.pdo_mapping {
            facts.push_str(", PDO-mappable");
        }
        if let Some(d) = sub
            .default_value
            .as_ref()
            .filter(|d| !d.text.trim().is_empty())
        {
            let _ = write!(facts, "; default `{}`", doc_line(&d.text).replace('`', "'"));
        }
        if let (Some(lo), Some(hi)) = (sub.low_limit(), sub.high_limit()) {
            let _ = write!(
                facts,
                "; limits `{}`..=`{}`",
                doc_line(&lo.text),
                doc_line(&hi.text)
            );
        }
        let description = sub
            .extra()
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case("Description"))
            .map(|(_, v)| doc_line(v));
        let title = if obj.is_simple() {
            &obj.name
        } else {
            &sub.name
        };
        let docs = |out: &mut String| {
            let _ = writeln!(out, "{indent}/// {}", doc_line(title));
            let _ = writeln!(out, "{indent}///");
            let _ = writeln!(out, "{indent}/// {facts}.");
            if let Some(d) = description.as_ref().filter(|d| !d.is_empty()) {
                let _ = writeln!(out, "{indent}///");
                let _ = writeln!(out, "{indent}/// {d}");
            }
        };
        let ctor = format!(
            "{krate}::Entry::new({:#06X}, {}, {krate}::DataType::{})",
            obj.index,
            sub.sub_index,
            variant(sub.data_type)
        );
        let emit = |out: &mut String, cfg_attr: Option<String>, ty: String| {
            docs(out);
            if let Some(attr) = cfg_attr {
                let _ = writeln!(out, "{indent}{attr}");
            }
            if indent.is_empty() {
                // Inside a module the module's attribute covers it.
                let _ = writeln!(out, "#[allow(dead_code)]");
            }
            let _ = writeln!(
                out,
                "{indent}pub const {name}: {krate}::Entry<{ty}> = {ctor};"
            );
        };
        let opaque = format!("{krate}::entry::Opaque");
        match rust_type(sub.data_type) {
            RustType::Plain(t) => emit(&mut self.out, None, t.to_owned()),
            RustType::Opaque => emit(&mut self.out, None, opaque),
            RustType::Alloc { owned } => {
                let owned = format!("{krate}::entry::{owned}");
                match &self.cfg.strings {
                    StringTypes::Owned => emit(&mut self.out, None, owned),
                    StringTypes::Opaque => emit(&mut self.out, None, opaque),
                    StringTypes::Feature(f) => {
                        emit(
                            &mut self.out,
                            Some(format!("#[cfg(feature = {f:?})]")),
                            owned,
                        );
                        emit(
                            &mut self.out,
                            Some(format!("#[cfg(not(feature = {f:?}))]")),
                            opaque,
                        );
                    }
                }
            }
        }
    }

    fn dictionary(&mut self, od: &ObjectDictionary) {
        let krate = self.cfg.crate_path.clone();
        let _ = writeln!(
            self.out,
            "/// Every sub-object of the dictionary in index order, with its default value's bytes."
        );
        let _ = writeln!(self.out, "#[allow(dead_code)]");
        let _ = writeln!(
            self.out,
            "pub static DICTIONARY: &[{krate}::entry::StaticSubObject] = &["
        );
        for obj in od.objects.values() {
            if matches!(obj.object_code, ObjectCode::DefType | ObjectCode::DefStruct) {
                continue;
            }
            for sub in obj.subs.values() {
                let (default, relative) =
                    match sub.default_value.as_ref().and_then(|d| d.value.as_ref()) {
                        Some(v) => (
                            format!("Some(&{:?})", v.value.to_le_bytes()),
                            v.node_id_relative,
                        ),
                        None => ("None".to_owned(), false),
                    };
                let _ = writeln!(
                    self.out,
                    "    {krate}::entry::StaticSubObject {{ index: {:#06X}, sub_index: {}, name: {:?}, data_type: {krate}::DataType::{}, access: {krate}::AccessType::{:?}, pdo_mapping: {}, default: {default}, default_adds_node_id: {relative} }},",
                    obj.index,
                    sub.sub_index,
                    sub.name,
                    variant(sub.data_type),
                    sub.access,
                    sub.pdo_mapping,
                );
            }
        }
        let _ = writeln!(self.out, "];");
    }
}

/// This crate's README, whose example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod crate_readme {}

/// The error convention (`docs/STYLE.md`): `Debug` prints the `Display` text, so a `main` (or a
/// build script's `unwrap`) that returns this crate's error prints the EDS errors line by line.
#[cfg(test)]
mod error_convention {
    #[test]
    fn main_prints_the_text() {
        let dir = std::env::temp_dir().join(format!("canola-codegen-error-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let eds = dir.join("garbage.eds");
        std::fs::write(&eds, "garbage\n").unwrap();
        let e = crate::Config::new()
            .out_dir(&dir)
            .compile(&eds)
            .unwrap_err();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(matches!(&e, crate::Error::Parse { error, .. } if error.error_count() > 0));
        let file = eds.display();
        assert_eq!(
            e.to_string(),
            format!(
                "{file}:1: error: `garbage` is neither a [section] header, a key=value pair nor \
                 a `;` comment\n{file}:1: error: no [section] header in the file: not an EDS or \
                 DCF file"
            )
        );
        assert_eq!(format!("{e:?}"), e.to_string());
    }
}
