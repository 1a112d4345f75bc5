//! The typed node client ([`Config::client`]): `client::Device` with one method per object over
//! the `canola` facade's SDO client, and a `Client` in each ARRAY/RECORD module with one method
//! per sub-object. Each method returns a handle typed by the object's access: `ReadOnly<T>`
//! (`ro`, `const`), `WriteOnly<T>` (`wo`) or `ReadWrite<T>`, so writing a read-only object does
//! not compile.

use std::fmt::Write as _;

use canola_od::{AccessType, Object, ObjectDictionary, SubObject};

use crate::{Config, Generator, RustType, StringTypes, doc_line, names, rust_type};

/// One method of a client: a sub-object's handle, or a record's `Client`.
pub(crate) enum Item {
    /// A sub-object: the entry constant's name, the handle type, the value type and the
    /// `#[cfg]` it needs.
    Entry {
        method: String,
        title: String,
        address: String,
        constant: String,
        handle: &'static str,
        ty: String,
        cfg: Option<String>,
    },
    /// An ARRAY or RECORD: its module.
    Record {
        method: String,
        title: String,
        index: u16,
        module: String,
    },
}

impl Item {
    /// The method for a sub-object whose entry constant is `constant`, if its type can be read
    /// and written (not for opaque entries).
    pub(crate) fn var(cfg: &Config, obj: &Object, sub: &SubObject, constant: &str) -> Option<Self> {
        if !cfg.client {
            return None;
        }
        let krate = &cfg.crate_path;
        let (ty, item_cfg) = match rust_type(sub.data_type) {
            RustType::Plain(t) => (t.to_owned(), None),
            RustType::Opaque => return None,
            RustType::Alloc { owned } => {
                let owned = format!("{krate}::entry::{owned}");
                match &cfg.strings {
                    StringTypes::Owned => (owned, None),
                    StringTypes::Opaque => return None,
                    StringTypes::Feature(f) => (owned, Some(format!("#[cfg(feature = {f:?})]"))),
                }
            }
        };
        let handle = match sub.access {
            AccessType::Ro | AccessType::Const => "ReadOnly",
            AccessType::Wo => "WriteOnly",
            AccessType::Rw | AccessType::Rwr | AccessType::Rww => "ReadWrite",
        };
        let title = if obj.is_simple() {
            obj.name.to_string()
        } else {
            format!("{}.{}", obj.name, sub.name)
        };
        let base = if obj.is_simple() {
            &obj.name
        } else {
            &sub.name
        };
        Some(Self::Entry {
            method: names::snake(base, &format!("sub_{}", sub.sub_index)),
            title,
            address: format!("{:#06X}:{:02X}", obj.index, sub.sub_index),
            constant: constant.to_owned(),
            handle,
            ty,
            cfg: item_cfg,
        })
    }

    /// The method for an ARRAY or RECORD generated as `module`.
    pub(crate) fn record(obj: &Object, module: &str) -> Self {
        Self::Record {
            method: module.to_owned(),
            title: obj.name.to_string(),
            index: obj.index,
            module: module.to_owned(),
        }
    }
}

impl Generator<'_> {
    /// The client module: the three handle types and `Device`.
    pub(crate) fn client(&mut self, od: &ObjectDictionary) {
        let facade = self.cfg.facade_path.clone();
        let krate = self.cfg.crate_path.clone();
        let device = match (&od.device_info.vendor_name, &od.device_info.product_name) {
            (Some(v), Some(p)) => format!("{} {}", doc_line(v), doc_line(p)),
            (Some(n), None) | (None, Some(n)) => doc_line(n),
            (None, None) => "the device".to_owned(),
        };
        let out = &mut self.out;
        let _ = writeln!(
            out,
            "/// Typed SDO access to {device}: [`client::Device`] has one method per object."
        );
        let _ = writeln!(out, "#[allow(dead_code)]");
        let _ = writeln!(out, "pub mod client {{");
        for (handle, what, read, write) in [
            (
                "ReadOnly",
                "An object the master can read (access `ro` or `const`).",
                true,
                false,
            ),
            (
                "WriteOnly",
                "An object the master can write (access `wo`).",
                false,
                true,
            ),
            (
                "ReadWrite",
                "An object the master can read and write.",
                true,
                true,
            ),
        ] {
            let _ = writeln!(out, "    /// {what}");
            let _ = writeln!(out, "    #[derive(Debug, Clone)]");
            let _ = writeln!(out, "    pub struct {handle}<T> {{");
            let _ = writeln!(out, "        node: {facade}::Node,");
            let _ = writeln!(out, "        entry: {krate}::Entry<T>,");
            let _ = writeln!(out, "    }}\n");
            let _ = writeln!(
                out,
                "    impl<T: {krate}::EntryValue + 'static> {handle}<T> {{"
            );
            let _ = writeln!(out, "        /// The handle of `entry` on `node`.");
            let _ = writeln!(
                out,
                "        pub fn new(node: {facade}::Node, entry: {krate}::Entry<T>) -> Self {{"
            );
            let _ = writeln!(out, "            Self {{ node, entry }}");
            let _ = writeln!(out, "        }}\n");
            let _ = writeln!(
                out,
                "        /// The typed entry: address and data type, for the facade's own calls."
            );
            let _ = writeln!(
                out,
                "        pub fn entry(&self) -> {krate}::Entry<T> {{\n            self.entry\n        }}"
            );
            if read {
                let _ = writeln!(
                    out,
                    "\n        /// Reads the object (SDO upload) and decodes it as its data type: `.wait()` or `.await`."
                );
                let _ = writeln!(
                    out,
                    "        pub fn read(&self) -> {facade}::Operation<'static, T> {{\n            self.node.sdo().read_entry(&self.entry)\n        }}"
                );
            }
            if write {
                let _ = writeln!(
                    out,
                    "\n        /// Writes the object (SDO download), encoded as its data type: `.wait()` or `.await`."
                );
                let _ = writeln!(
                    out,
                    "        pub fn write(&self, value: T) -> {facade}::Operation<'static, ()> {{\n            self.node.sdo().write_entry(&self.entry, &value)\n        }}"
                );
            }
            let _ = writeln!(out, "    }}\n");
        }
        let _ = writeln!(
            out,
            "    /// One node that is {device}: a method per object, each giving a typed handle."
        );
        let _ = writeln!(out, "    #[derive(Debug, Clone)]");
        let _ = writeln!(out, "    pub struct Device {{");
        let _ = writeln!(out, "        node: {facade}::Node,");
        let _ = writeln!(out, "    }}\n");
        let _ = writeln!(out, "    impl Device {{");
        let _ = writeln!(
            out,
            "        /// The client of `node` (from `Network::node`).\n        pub fn new(node: {facade}::Node) -> Self {{\n            Self {{ node }}\n        }}\n"
        );
        let _ = writeln!(
            out,
            "        /// The node.\n        pub fn node(&self) -> &{facade}::Node {{\n            &self.node\n        }}"
        );
        let mut scope = names::Scope::default();
        scope.reserve("new");
        scope.reserve("node");
        for item in std::mem::take(&mut self.client_items) {
            match item {
                Item::Entry {
                    method,
                    title,
                    address,
                    constant,
                    handle,
                    ty,
                    cfg,
                } => {
                    let method = scope.unique(method, &address[2..6].to_ascii_lowercase());
                    let out = &mut self.out;
                    let _ = writeln!(out, "\n        /// {} (`{address}`).", doc_line(&title));
                    if let Some(c) = &cfg {
                        let _ = writeln!(out, "        {c}");
                    }
                    let _ = writeln!(
                        out,
                        "        pub fn {method}(&self) -> {handle}<{ty}> {{\n            {handle}::new(self.node.clone(), super::{constant})\n        }}"
                    );
                }
                Item::Record {
                    method,
                    title,
                    index,
                    module,
                } => {
                    let method = scope.unique(method, &format!("{index:04x}"));
                    let out = &mut self.out;
                    let _ = writeln!(
                        out,
                        "\n        /// {} (`{index:#06X}`): its sub-objects.",
                        doc_line(&title)
                    );
                    let _ = writeln!(
                        out,
                        "        pub fn {method}(&self) -> super::{module}::Client {{\n            super::{module}::Client::new(self.node.clone())\n        }}"
                    );
                }
            }
        }
        let _ = writeln!(self.out, "    }}\n}}");
    }

    /// `Client` inside an ARRAY/RECORD module: one method per sub-object.
    pub(crate) fn record_client(&mut self, obj: &Object, subs: &[Item]) {
        let facade = &self.cfg.facade_path;
        let out = &mut self.out;
        let _ = writeln!(
            out,
            "\n    /// SDO access to the sub-objects of {}.",
            doc_line(&obj.name)
        );
        let _ = writeln!(out, "    #[derive(Debug, Clone)]");
        let _ = writeln!(out, "    pub struct Client {{");
        let _ = writeln!(out, "        node: {facade}::Node,");
        let _ = writeln!(out, "    }}\n");
        let _ = writeln!(out, "    impl Client {{");
        let _ = writeln!(
            out,
            "        /// The sub-objects on `node`.\n        pub fn new(node: {facade}::Node) -> Self {{\n            Self {{ node }}\n        }}"
        );
        let mut scope = names::Scope::default();
        scope.reserve("new");
        for item in subs {
            let Item::Entry {
                method,
                title,
                address,
                constant,
                handle,
                ty,
                cfg,
            } = item
            else {
                continue;
            };
            let method = scope.unique(method.clone(), &address[7..].to_ascii_lowercase());
            let _ = writeln!(out, "\n        /// {} (`{address}`).", doc_line(title));
            if let Some(c) = cfg {
                let _ = writeln!(out, "        {c}");
            }
            let _ = writeln!(
                out,
                "        pub fn {method}(&self) -> super::client::{handle}<{ty}> {{\n            super::client::{handle}::new(self.node.clone(), {constant})\n        }}"
            );
        }
        let _ = writeln!(out, "    }}");
    }
}
