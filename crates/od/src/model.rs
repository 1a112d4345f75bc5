//! The object dictionary model that an EDS or DCF file (CiA 306) describes: file and device
//! information, the object lists, and the objects of CiA 301 §7.4 with their sub-objects.
//!
//! Every object is stored uniformly as a map of sub-objects: a VAR, DOMAIN or DEFTYPE object has
//! exactly one sub-object, sub-index 0, which carries its data type, access type and values; an
//! ARRAY or RECORD has one sub-object per `[xxxxsubN]` section (or per `CompactSubObj` entry).
//! Values are kept both as the source text and as typed [`EdsValue`]s ([`FieldValue`]).

use alloc::boxed::Box;
use alloc::collections::BTreeMap;
use alloc::string::String;
use alloc::vec::Vec;

use compact_str::CompactString;

use crate::types::{AccessType, DataType, ObjectCode};
use crate::value::{EdsValue, TextError, TextNotes, Value};

/// A 1-based line number in the source file (0 when the item was not read from a file).
///
/// Two `Line`s always compare equal: where an object came from is not part of what it is, so a
/// parsed model equals the model parsed back from its written form.
#[derive(Debug, Clone, Copy, Default, Eq)]
pub struct Line(pub u32);

impl PartialEq for Line {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// An unrecognised `key=value` pair, kept in file order so the writer can reproduce it.
pub type Extra = Vec<(CompactString, CompactString)>;

/// A value field (`DefaultValue`, `LowLimit`, `HighLimit`, `ParameterValue`): the text as written
/// (trimmed) and its typed reading for the sub-object's data type.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldValue {
    /// The text as written in the file, trimmed of surrounding whitespace.
    pub text: CompactString,
    /// The typed value; `None` when the text is empty or could not be read as the data type
    /// (the parser then reported a warning).
    pub value: Option<EdsValue>,
}

impl FieldValue {
    /// A field from a typed value, with its canonical text.
    pub fn from_value(value: EdsValue) -> Self {
        Self {
            text: value.to_eds_text().into(),
            value: Some(value),
        }
    }

    /// A field from text, decoded for `data_type`. Returns the decoding error (if any) and the
    /// non-standard spellings that were accepted alongside the field.
    pub fn from_text(data_type: DataType, text: &str) -> (Self, Result<TextNotes, TextError>) {
        let text = crate::value::trim(text);
        match EdsValue::parse(data_type, text) {
            Ok((v, notes)) => (
                Self {
                    text: text.into(),
                    value: Some(v),
                },
                Ok(notes),
            ),
            Err(e) => (
                Self {
                    text: text.into(),
                    value: None,
                },
                Err(e),
            ),
        }
    }

    /// The value with `$NODEID` resolved for `node_id`.
    pub fn resolve(&self, node_id: u8) -> Option<Value> {
        self.value.as_ref().map(|v| v.resolve(node_id))
    }
}

/// One sub-object (a VAR's only entry, or one sub-index of an ARRAY/RECORD).
///
/// The keys that most files give for every entry are fields; the rarely present ones
/// (`LowLimit`, `HighLimit`, `ParameterValue`, `Denotation`, an invalid `AccessType` text and
/// unknown keys) live out of line in [`SubObjectExtras`], allocated only when one is present.
/// A dictionary holds tens of thousands of sub-objects, so this keeps a parsed model (and the
/// page faults of building it) about three times smaller.
#[derive(Debug, Clone)]
pub struct SubObject {
    /// Sub-index.
    pub sub_index: u8,
    /// `ObjectType` of the sub-object section (VAR unless the file says otherwise).
    pub object_code: ObjectCode,
    /// `DataType`.
    pub data_type: DataType,
    /// `AccessType` ([`AccessType::Ro`] when the file's text was none of the six CiA 306
    /// spellings; the text is then in [`SubObjectExtras::access_raw`]).
    pub access: AccessType,
    /// `PDOMapping`: whether the entry may be mapped into a PDO.
    pub pdo_mapping: bool,
    /// `ParameterName`.
    pub name: CompactString,
    /// `DefaultValue`.
    pub default_value: Option<FieldValue>,
    /// `ObjFlags`.
    pub obj_flags: Option<u32>,
    /// Line of the section header (for a VAR: of the object's section).
    pub line: Line,
    extras: Option<Box<SubObjectExtras>>,
}

/// The keys of a sub-object section that most files leave out (see [`SubObject`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SubObjectExtras {
    /// The `AccessType` text when it was none of the six CiA 306 spellings.
    pub access_raw: Option<String>,
    /// `LowLimit`.
    pub low_limit: Option<FieldValue>,
    /// `HighLimit`.
    pub high_limit: Option<FieldValue>,
    /// `ParameterValue` (DCF).
    pub parameter_value: Option<FieldValue>,
    /// `Denotation` (DCF).
    pub denotation: Option<String>,
    /// Other keys of the section, in file order.
    pub extra: Extra,
}

/// What [`SubObject::extras`] returns when none are present.
static NO_EXTRAS: SubObjectExtras = SubObjectExtras {
    access_raw: None,
    low_limit: None,
    high_limit: None,
    parameter_value: None,
    denotation: None,
    extra: Vec::new(),
};

impl PartialEq for SubObject {
    /// Absent extras equal empty ones.
    fn eq(&self, other: &Self) -> bool {
        self.sub_index == other.sub_index
            && self.object_code == other.object_code
            && self.data_type == other.data_type
            && self.access == other.access
            && self.pdo_mapping == other.pdo_mapping
            && self.name == other.name
            && self.default_value == other.default_value
            && self.obj_flags == other.obj_flags
            && self.line == other.line
            && self.extras() == other.extras()
    }
}

impl SubObject {
    /// A sub-object with the given name, type and access; no values.
    pub fn new(
        sub_index: u8,
        name: impl Into<CompactString>,
        data_type: DataType,
        access: AccessType,
    ) -> Self {
        Self {
            sub_index,
            object_code: ObjectCode::Var,
            data_type,
            access,
            pdo_mapping: false,
            name: name.into(),
            default_value: None,
            obj_flags: None,
            line: Line(0),
            extras: None,
        }
    }

    /// Sets `DefaultValue` from a typed value (builder style).
    pub fn with_default(mut self, value: EdsValue) -> Self {
        self.default_value = Some(FieldValue::from_value(value));
        self
    }

    /// Sets `PDOMapping` (builder style).
    pub fn with_pdo_mapping(mut self, mappable: bool) -> Self {
        self.pdo_mapping = mappable;
        self
    }

    /// The rarely present keys (all empty when the file gave none).
    pub fn extras(&self) -> &SubObjectExtras {
        self.extras.as_deref().unwrap_or(&NO_EXTRAS)
    }

    /// Mutable access to the rarely present keys (allocated on first use).
    pub fn extras_mut(&mut self) -> &mut SubObjectExtras {
        self.extras.get_or_insert_with(Default::default)
    }

    /// `LowLimit`.
    pub fn low_limit(&self) -> Option<&FieldValue> {
        self.extras().low_limit.as_ref()
    }

    /// `HighLimit`.
    pub fn high_limit(&self) -> Option<&FieldValue> {
        self.extras().high_limit.as_ref()
    }

    /// `ParameterValue` (DCF).
    pub fn parameter_value(&self) -> Option<&FieldValue> {
        self.extras().parameter_value.as_ref()
    }

    /// `Denotation` (DCF).
    pub fn denotation(&self) -> Option<&str> {
        self.extras().denotation.as_deref()
    }

    /// The `AccessType` text when it was none of the six CiA 306 spellings.
    pub fn access_raw(&self) -> Option<&str> {
        self.extras().access_raw.as_deref()
    }

    /// Other keys of the section, in file order.
    pub fn extra(&self) -> &[(CompactString, CompactString)] {
        &self.extras().extra
    }

    /// The value a device holds after configuration: `ParameterValue` if present, else
    /// `DefaultValue`, with `$NODEID` resolved.
    pub fn effective_value(&self, node_id: u8) -> Option<Value> {
        self.parameter_value()
            .and_then(|f| f.resolve(node_id))
            .or_else(|| self.default_value.as_ref().and_then(|f| f.resolve(node_id)))
    }
}

/// The sub-objects of one object, ordered by sub-index.
///
/// A sorted vector rather than a map: most objects have one to a few dozen sub-objects, and a
/// vector keeps them compact and cache-friendly. Look-up is a binary search.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SubObjects(Vec<SubObject>);

impl SubObjects {
    /// No sub-objects.
    pub const fn new() -> Self {
        Self(Vec::new())
    }

    /// Number of sub-objects.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    fn position(&self, sub_index: u8) -> Result<usize, usize> {
        self.0.binary_search_by_key(&sub_index, |s| s.sub_index)
    }

    /// The sub-object with this sub-index.
    pub fn get(&self, sub_index: u8) -> Option<&SubObject> {
        self.position(sub_index).ok().and_then(|i| self.0.get(i))
    }

    /// Mutable access to the sub-object with this sub-index.
    pub fn get_mut(&mut self, sub_index: u8) -> Option<&mut SubObject> {
        self.position(sub_index)
            .ok()
            .and_then(|i| self.0.get_mut(i))
    }

    /// True when this sub-index exists.
    pub fn contains(&self, sub_index: u8) -> bool {
        self.position(sub_index).is_ok()
    }

    /// Inserts `sub` at its `sub_index`, returning the one it replaces.
    pub fn insert(&mut self, sub: SubObject) -> Option<SubObject> {
        match self.position(sub.sub_index) {
            Ok(i) => self.0.get_mut(i).map(|slot| core::mem::replace(slot, sub)),
            Err(i) => {
                self.0.insert(i, sub);
                None
            }
        }
    }

    /// Removes and returns the sub-object with this sub-index.
    pub fn remove(&mut self, sub_index: u8) -> Option<SubObject> {
        self.position(sub_index).ok().map(|i| self.0.remove(i))
    }

    /// The sub-objects in sub-index order.
    pub fn values(&self) -> core::slice::Iter<'_, SubObject> {
        self.0.iter()
    }

    /// Mutable sub-objects in sub-index order (do not change their `sub_index`).
    pub fn values_mut(&mut self) -> core::slice::IterMut<'_, SubObject> {
        self.0.iter_mut()
    }

    /// The sub-indices in order.
    pub fn keys(&self) -> impl DoubleEndedIterator<Item = u8> + '_ {
        self.0.iter().map(|s| s.sub_index)
    }

    /// The highest sub-index present.
    pub fn highest(&self) -> Option<u8> {
        self.0.last().map(|s| s.sub_index)
    }

    /// The sub-objects as a slice, in sub-index order.
    pub fn as_slice(&self) -> &[SubObject] {
        &self.0
    }
}

impl FromIterator<SubObject> for SubObjects {
    fn from_iter<I: IntoIterator<Item = SubObject>>(iter: I) -> Self {
        let mut v: Vec<SubObject> = iter.into_iter().collect();
        v.sort_by_key(|s| s.sub_index);
        // Later duplicates win, as with repeated inserts.
        let mut out: Vec<SubObject> = Vec::with_capacity(v.len());
        for s in v {
            match out.last_mut() {
                Some(last) if last.sub_index == s.sub_index => *last = s,
                _ => out.push(s),
            }
        }
        Self(out)
    }
}

impl From<Vec<SubObject>> for SubObjects {
    /// Sorts by sub-index (keeping the later of two equal sub-indices) in place.
    fn from(mut v: Vec<SubObject>) -> Self {
        if !v.windows(2).all(|w| w[0].sub_index < w[1].sub_index) {
            v.sort_by_key(|s| s.sub_index);
            v.dedup_by(|later, kept| {
                if later.sub_index == kept.sub_index {
                    core::mem::swap(later, kept);
                    true
                } else {
                    false
                }
            });
        }
        Self(v)
    }
}

impl<'a> IntoIterator for &'a SubObjects {
    type Item = &'a SubObject;
    type IntoIter = core::slice::Iter<'a, SubObject>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

/// One object (one index) of the dictionary.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    /// Index, 0x0001..=0xFFFF.
    pub index: u16,
    /// `ParameterName`.
    pub name: CompactString,
    /// `ObjectType` (VAR when the file omits it, as CiA 306 prescribes).
    pub object_code: ObjectCode,
    /// `SubNumber` as declared (ARRAY/RECORD); `None` when absent. The writer writes it only
    /// when present; the linter compares it with [`Object::subs`].
    pub sub_number: Option<u8>,
    /// `ObjFlags` of an ARRAY/RECORD object section (a VAR's flags sit on sub-index 0).
    pub obj_flags: Option<u32>,
    /// Objects listed in the `[xxxxObjectLinks]` section.
    pub object_links: Vec<u16>,
    /// Sub-objects by sub-index. A VAR/DOMAIN/DEFTYPE has exactly sub-index 0.
    pub subs: SubObjects,
    /// Other keys of the object section.
    pub extra: Extra,
    /// Line of the `[xxxx]` section header.
    pub line: Line,
}

impl Object {
    /// A VAR object whose single entry is `sub` (its sub-index is forced to 0 and its name to
    /// the object name).
    pub fn var(index: u16, mut sub: SubObject) -> Self {
        sub.sub_index = 0;
        let name = sub.name.clone();
        // Exactly one element: `insert` would reserve room for four.
        let subs = SubObjects(alloc::vec![sub]);
        Self {
            index,
            name,
            object_code: ObjectCode::Var,
            sub_number: None,
            obj_flags: None,
            object_links: Vec::new(),
            subs,
            extra: Vec::new(),
            line: Line(0),
        }
    }

    /// An ARRAY or RECORD (`code`) with the given sub-objects; `SubNumber` is set to their count.
    pub fn complex(
        index: u16,
        name: impl Into<CompactString>,
        code: ObjectCode,
        subs: impl IntoIterator<Item = SubObject>,
    ) -> Self {
        let subs: SubObjects = subs.into_iter().collect();
        Self {
            index,
            name: name.into(),
            object_code: code,
            sub_number: u8::try_from(subs.len()).ok(),
            obj_flags: None,
            object_links: Vec::new(),
            subs,
            extra: Vec::new(),
            line: Line(0),
        }
    }

    /// True for VAR, DOMAIN, DEFTYPE and NULL objects, whose data is sub-index 0 alone.
    pub fn is_simple(&self) -> bool {
        self.object_code.is_simple()
    }

    /// A sub-object by sub-index.
    pub fn sub(&self, sub_index: u8) -> Option<&SubObject> {
        self.subs.get(sub_index)
    }

    /// The sub-object carrying a VAR's data (sub-index 0).
    pub fn var_entry(&self) -> Option<&SubObject> {
        self.subs.get(0)
    }
}

/// The baud rates of CiA 306 `[DeviceInfo]` keys `BaudRate_10` .. `BaudRate_1000`, in kbit/s.
pub const BAUD_RATES_KBIT: [u16; 8] = [10, 20, 50, 125, 250, 500, 800, 1000];

/// `[FileInfo]`. Fields are kept as text; absent keys are `None`.
#[derive(Debug, Clone, Default, PartialEq)]
#[allow(missing_docs)]
pub struct FileInfo {
    pub file_name: Option<String>,
    pub file_version: Option<String>,
    pub file_revision: Option<String>,
    /// `EDSVersion` as written (CiA 306 says `4.0`).
    pub eds_version: Option<String>,
    pub description: Option<String>,
    pub creation_time: Option<String>,
    pub creation_date: Option<String>,
    pub created_by: Option<String>,
    pub modification_time: Option<String>,
    pub modification_date: Option<String>,
    pub modified_by: Option<String>,
    /// Other keys (DCF: `LastEDS`, ...).
    pub extra: Extra,
}

/// `[DeviceInfo]`; absent keys are `None`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DeviceInfo {
    /// `VendorName`.
    pub vendor_name: Option<String>,
    /// `VendorNumber` (identity 0x1018/1).
    pub vendor_number: Option<u32>,
    /// `ProductName`.
    pub product_name: Option<String>,
    /// `ProductNumber` (0x1018/2).
    pub product_number: Option<u32>,
    /// `RevisionNumber` (0x1018/3).
    pub revision_number: Option<u32>,
    /// `OrderCode`.
    pub order_code: Option<String>,
    /// `BaudRate_10` .. `BaudRate_1000`, in the order of [`BAUD_RATES_KBIT`].
    pub baud_rates: [Option<bool>; 8],
    /// `SimpleBootUpMaster`.
    pub simple_boot_up_master: Option<bool>,
    /// `SimpleBootUpSlave`.
    pub simple_boot_up_slave: Option<bool>,
    /// `Granularity`: mapping granularity in bits (0 = no PDO mapping, 8 = byte-wise).
    pub granularity: Option<u8>,
    /// `DynamicChannelsSupported` (CiA 302 dynamic SDO channels).
    pub dynamic_channels_supported: Option<u8>,
    /// `GroupMessaging`.
    pub group_messaging: Option<bool>,
    /// `NrOfRXPDO`.
    pub nr_of_rx_pdo: Option<u16>,
    /// `NrOfTXPDO`.
    pub nr_of_tx_pdo: Option<u16>,
    /// `LSS_Supported`.
    pub lss_supported: Option<bool>,
    /// `CompactPDO`: bit mask of PDO communication sub-indices that are implicitly present.
    pub compact_pdo: Option<u8>,
    /// Other keys.
    pub extra: Extra,
}

impl DeviceInfo {
    /// The supported baud rates in kbit/s.
    pub fn supported_baud_rates(&self) -> impl Iterator<Item = u16> + '_ {
        BAUD_RATES_KBIT
            .iter()
            .zip(self.baud_rates.iter())
            .filter(|(_, s)| **s == Some(true))
            .map(|(b, _)| *b)
    }
}

/// `[DeviceComissioning]` of a DCF (CiA 306 spells it with one "m"; files with "mm" are read too).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DeviceCommissioning {
    /// `NodeID`.
    pub node_id: Option<u8>,
    /// `NodeName`.
    pub node_name: Option<String>,
    /// `Baudrate` in kbit/s.
    pub baudrate: Option<u16>,
    /// `NetNumber`.
    pub net_number: Option<u32>,
    /// `NetworkName`.
    pub network_name: Option<String>,
    /// `CANopenManager`.
    pub canopen_manager: Option<bool>,
    /// `LSS_SerialNumber`.
    pub lss_serial_number: Option<u32>,
    /// Other keys.
    pub extra: Extra,
}

/// A section this crate does not interpret (module sections such as `[SupportedModules]` or
/// `[M1ModuleInfo]`, tool sections such as `[ToolInfos]`), kept verbatim.
#[derive(Debug, Clone, PartialEq)]
pub struct RawSection {
    /// Section name without brackets.
    pub name: String,
    /// Its `key=value` pairs in file order.
    pub entries: Extra,
    /// Line of the header.
    pub line: Line,
}

/// A whole object dictionary as an EDS or DCF file describes it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObjectDictionary {
    /// `[FileInfo]`.
    pub file_info: FileInfo,
    /// `[DeviceInfo]`.
    pub device_info: DeviceInfo,
    /// `[DummyUsage]`: data type index (`Dummy0001` .. `Dummy0007`) to whether it may be
    /// mapped as a PDO dummy entry.
    pub dummy_usage: BTreeMap<u16, bool>,
    /// `[Comments]` lines.
    pub comments: Vec<String>,
    /// `[MandatoryObjects]` in file order.
    pub mandatory_objects: Vec<u16>,
    /// `[OptionalObjects]` in file order.
    pub optional_objects: Vec<u16>,
    /// `[ManufacturerObjects]` in file order.
    pub manufacturer_objects: Vec<u16>,
    /// `[DeviceComissioning]` (DCF only).
    pub device_commissioning: Option<DeviceCommissioning>,
    /// Objects by index.
    pub objects: BTreeMap<u16, Object>,
    /// Sections kept verbatim, in file order.
    pub other_sections: Vec<RawSection>,
    /// Header lines of `[MandatoryObjects]`, `[OptionalObjects]` and `[ManufacturerObjects]`
    /// (for diagnostics; 0 when absent).
    pub object_list_lines: [Line; 3],
}

impl ObjectDictionary {
    /// An object by index.
    pub fn get(&self, index: u16) -> Option<&Object> {
        self.objects.get(&index)
    }

    /// A sub-object by index and sub-index (a VAR answers at sub-index 0).
    pub fn sub(&self, index: u16, sub_index: u8) -> Option<&SubObject> {
        self.objects.get(&index).and_then(|o| o.subs.get(sub_index))
    }

    /// Mutable access to a sub-object.
    pub fn sub_mut(&mut self, index: u16, sub_index: u8) -> Option<&mut SubObject> {
        self.objects
            .get_mut(&index)
            .and_then(|o| o.subs.get_mut(sub_index))
    }

    /// Inserts (or replaces) an object.
    pub fn insert(&mut self, object: Object) -> Option<Object> {
        self.objects.insert(object.index, object)
    }

    /// An object by name, compared without regard to case (`"producer heartbeat time"` finds
    /// `Producer heartbeat time`). The first in index order when names repeat.
    pub fn find_object(&self, name: &str) -> Option<&Object> {
        self.objects.values().find(|o| same_name(&o.name, name))
    }

    /// The address of a value by name: an object's name for a VAR (`"Producer heartbeat
    /// time"`), the object's and the sub-object's name for an entry of an ARRAY or RECORD,
    /// separated by `/` or `.` (`"Identity object/Vendor ID"`, `"Identity object.Vendor ID"`
    /// as python-canopen writes it, or the printed form of [`display_name`](Self::display_name),
    /// `"Identity object / Vendor ID"`), case-insensitive, blanks around the separator ignored.
    /// A name that contains separators itself is tried whole first, then split at each
    /// separator from the left. `None` when nothing matches, and for the name of an ARRAY or
    /// RECORD alone (it has no single value).
    pub fn find(&self, name: &str) -> Option<crate::ObjectAddress> {
        if let Some(o) = self.find_object(name.trim())
            && o.is_simple()
        {
            return Some(crate::ObjectAddress::new(o.index, 0));
        }
        for (at, _) in name.match_indices(['/', '.']) {
            let (object, sub) = (name[..at].trim(), name[at + 1..].trim());
            let found = self
                .objects
                .values()
                .filter(|o| same_name(&o.name, object))
                .find_map(|o| {
                    o.subs
                        .values()
                        .find(|s| same_name(&s.name, sub))
                        .map(|s| (o, s))
                });
            if let Some((o, s)) = found {
                return Some(crate::ObjectAddress::new(o.index, s.sub_index));
            }
        }
        None
    }

    /// The name of the value at `at` as the stack prints it: the object's name for a VAR (or
    /// a sub-index the object does not have), `Object / Sub-object` for an entry of an ARRAY or
    /// RECORD (`"Identity object / Vendor ID"`). [`find`](Self::find) takes it back. `None`
    /// when the dictionary has no object at `at.index`.
    pub fn display_name(&self, at: crate::ObjectAddress) -> Option<String> {
        let obj = self.get(at.index)?;
        Some(match obj.sub(at.sub_index) {
            Some(sub) if !obj.is_simple() => alloc::format!("{} / {}", obj.name, sub.name),
            _ => String::from(obj.name.as_str()),
        })
    }

    /// Iterates over every (index, sub-object) pair in index order.
    pub fn entries(&self) -> impl Iterator<Item = (u16, &SubObject)> + '_ {
        self.objects
            .values()
            .flat_map(|o| o.subs.values().map(move |s| (o.index, s)))
    }

    /// Rebuilds the three object lists from the objects present: 0x1000, 0x1001 and 0x1018 are
    /// mandatory (CiA 301), 0x2000..=0x5FFF are manufacturer objects, every other index from
    /// 0x1000 up is optional (data type definitions below 0x1000 are listed nowhere).
    pub fn rebuild_object_lists(&mut self) {
        self.mandatory_objects.clear();
        self.optional_objects.clear();
        self.manufacturer_objects.clear();
        for &index in self.objects.keys() {
            match index {
                0x1000 | 0x1001 | 0x1018 => self.mandatory_objects.push(index),
                0x2000..=0x5FFF => self.manufacturer_objects.push(index),
                0x1000.. => self.optional_objects.push(index),
                _ => {}
            }
        }
    }
}

/// Whether two names are equal without regard to case.
fn same_name(a: &str, b: &str) -> bool {
    a.chars()
        .flat_map(char::to_lowercase)
        .eq(b.chars().flat_map(char::to_lowercase))
}
