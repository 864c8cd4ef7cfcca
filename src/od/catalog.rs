//! The object catalog: names, types, access, units and limits of the objects drivedeck
//! knows. The built-in one is `assets/od/nanotec.json` (protocol notes §4).

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use super::{Access, Address, DataType, Error, Role, Value};

/// Where an object sits in the CiA 301 index ranges.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Group {
    /// 1000h-1FFFh: communication and identification.
    Communication,
    /// 2000h-5FFFh: manufacturer-specific (Nanotec).
    Manufacturer,
    /// 6000h-9FFFh: the CiA 402 drive profile.
    Profile,
}

impl Group {
    pub fn of_index(index: u16) -> Group {
        match index {
            0x0000..=0x1FFF => Group::Communication,
            0x2000..=0x5FFF => Group::Manufacturer,
            _ => Group::Profile,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Group::Communication => "Communication",
            Group::Manufacturer => "Manufacturer",
            Group::Profile => "Drive profile",
        }
    }
}

impl fmt::Display for Group {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One entry (one subindex) with everything the UI and the simulator need.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    pub address: Address,
    /// The object's name (shared by its subindices).
    pub object_name: String,
    /// The subindex's own name; equals `object_name` for a plain variable.
    pub name: String,
    pub dtype: DataType,
    pub access: Access,
    pub unit: Option<String>,
    pub description: String,
    pub default: Option<Value>,
    pub min: Option<Value>,
    pub max: Option<Value>,
    pub group: Group,
    /// Setting, command, process data or read-only: whether a backup saves it and a
    /// restore may write it. Set by [`Role::of`] (built-in catalog) or [`Role::of_eds`].
    pub role: Role,
    /// Names of single bits, ascending (status and control words, digital inputs, the
    /// error register); empty where the catalog names none.
    pub bits: Vec<(u8, String)>,
}

impl Entry {
    /// The name to show in one line: `Identity / Vendor-ID`, or the object name alone.
    pub fn full_name(&self) -> String {
        if self.name == self.object_name {
            self.name.clone()
        } else {
            format!("{} / {}", self.object_name, self.name)
        }
    }

    /// Check a value against the entry's type and limits.
    pub fn check(&self, value: &Value) -> Result<(), Error> {
        value.to_le_bytes(self.dtype)?;
        if let (Some(v), Some(max)) = (value.as_f64(), self.max.as_ref().and_then(Value::as_f64))
            && v > max
        {
            return Err(Error::TooHigh {
                value: value.to_string(),
                max: self.max.as_ref().map(Value::to_string).unwrap_or_default(),
            });
        }
        if let (Some(v), Some(min)) = (value.as_f64(), self.min.as_ref().and_then(Value::as_f64))
            && v < min
        {
            return Err(Error::TooLow {
                value: value.to_string(),
                min: self.min.as_ref().map(Value::to_string).unwrap_or_default(),
            });
        }
        Ok(())
    }
}

/// A set of known entries, ordered by address.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Catalog {
    entries: BTreeMap<Address, Entry>,
}

/// The built-in catalog's JSON, embedded in the binary.
pub const BUILTIN_JSON: &str = include_str!("../../assets/od/nanotec.json");

static BUILTIN: std::sync::LazyLock<Catalog> =
    std::sync::LazyLock::new(|| Catalog::builtin().unwrap_or_default());

/// The built-in catalog, parsed once. (Its JSON is compiled in and covered by tests; were
/// it ever broken the catalog would be empty, never a panic.)
pub fn builtin() -> &'static Catalog {
    &BUILTIN
}

impl Catalog {
    /// The built-in Nanotec catalog. It is part of the binary and tested, so a failure
    /// here is a build defect; the error still says where.
    pub fn builtin() -> Result<Catalog, Error> {
        Catalog::from_json(BUILTIN_JSON)
    }

    pub fn from_json(text: &str) -> Result<Catalog, Error> {
        let file: CatalogFile =
            serde_json::from_str(text).map_err(|e| Error::Catalog(e.to_string()))?;
        let mut catalog = Catalog::default();
        for object in file.objects {
            object.add_to(&mut catalog)?;
        }
        Ok(catalog)
    }

    pub fn insert(&mut self, entry: Entry) {
        self.entries.insert(entry.address, entry);
    }

    pub fn get(&self, address: Address) -> Option<&Entry> {
        self.entries.get(&address)
    }

    /// Whether any subindex of `index` is known.
    pub fn has_index(&self, index: u16) -> bool {
        self.entries
            .range(Address::new(index, 0)..=Address::new(index, 0xFF))
            .next()
            .is_some()
    }

    pub fn entries(&self) -> impl Iterator<Item = &Entry> {
        self.entries.values()
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Entries whose name contains `filter` (case-insensitive) or whose address it
    /// names: `6064` or `6064h` that index, `60` every index starting 60, `1018:01` (also
    /// `1018h:1h`, `0x1018.1`) that one entry. Empty: every entry.
    pub fn filter<'a>(&'a self, filter: &'a str) -> impl Iterator<Item = &'a Entry> + 'a {
        let needle = filter.trim().to_lowercase();
        let address = AddressFilter::parse(&needle);
        self.entries.values().filter(move |e| {
            needle.is_empty()
                || e.full_name().to_lowercase().contains(&needle)
                || address.as_ref().is_some_and(|a| a.matches(e.address))
        })
    }
}

/// The address part of a catalog filter.
#[derive(Clone, Debug, PartialEq)]
enum AddressFilter {
    /// Indices whose four hex digits start with these (lower case).
    IndexPrefix(String),
    Exact(Address),
}

impl AddressFilter {
    fn parse(needle: &str) -> Option<AddressFilter> {
        let t = needle.strip_prefix("0x").unwrap_or(needle);
        let hex = |part: &str| -> Option<String> {
            let part = part.strip_suffix('h').unwrap_or(part);
            let part = part.strip_prefix("0x").unwrap_or(part);
            (!part.is_empty() && part.len() <= 4 && part.chars().all(|c| c.is_ascii_hexdigit()))
                .then(|| part.to_owned())
        };
        match t.split_once([':', '.', '/']) {
            None => hex(t).map(AddressFilter::IndexPrefix),
            Some((index, "")) => {
                let index = hex(index)?;
                Some(AddressFilter::IndexPrefix(format!("{:0>4}", index)))
            }
            Some((index, sub)) => {
                let index = u16::from_str_radix(&hex(index)?, 16).ok()?;
                let sub = u8::from_str_radix(&hex(sub)?, 16).ok()?;
                Some(AddressFilter::Exact(Address::new(index, sub)))
            }
        }
    }

    fn matches(&self, address: Address) -> bool {
        match self {
            AddressFilter::IndexPrefix(digits) => {
                format!("{:04x}", address.index).starts_with(digits.as_str())
            }
            AddressFilter::Exact(a) => *a == address,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CatalogFile {
    #[serde(default, rename = "$comment")]
    _comment: Option<String>,
    objects: Vec<ObjectDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDef {
    index: String,
    name: String,
    #[serde(default)]
    description: String,
    #[serde(rename = "type")]
    dtype: Option<DataType>,
    access: Option<Access>,
    unit: Option<String>,
    default: Option<String>,
    min: Option<String>,
    max: Option<String>,
    #[serde(default)]
    subs: Vec<SubDef>,
    /// Bit number (decimal) → name.
    #[serde(default)]
    bits: BTreeMap<String, String>,
    /// How firm the public record is (H, M, L; protocol notes §0.2); kept for reviewers.
    #[serde(default, rename = "confidence")]
    _confidence: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SubDef {
    sub: String,
    name: String,
    #[serde(default)]
    description: String,
    #[serde(rename = "type")]
    dtype: DataType,
    access: Access,
    unit: Option<String>,
    default: Option<String>,
    min: Option<String>,
    max: Option<String>,
    #[serde(default)]
    bits: BTreeMap<String, String>,
}

/// The named bits of an object of type `dtype`, checked: a bit number must be decimal and
/// inside the type.
fn bit_names(
    bits: &BTreeMap<String, String>,
    dtype: DataType,
    address: Address,
) -> Result<Vec<(u8, String)>, Error> {
    let width = dtype.size().unwrap_or(0) * 8;
    let mut named = Vec::with_capacity(bits.len());
    for (bit, name) in bits {
        let number = bit
            .parse::<u8>()
            .ok()
            .filter(|b| usize::from(*b) < width)
            .ok_or_else(|| {
                Error::Catalog(format!(
                    "{address} bit '{bit}': not a bit of a {} ({width} bits)",
                    dtype.short_name()
                ))
            })?;
        named.push((number, name.clone()));
    }
    named.sort_by_key(|(bit, _)| *bit);
    Ok(named)
}

fn parse_hex_u32(text: &str, what: &str, limit: u32) -> Result<u32, Error> {
    crate::number::parse_integer(text, true)
        .and_then(|v| u32::try_from(v).ok())
        .filter(|v| *v <= limit)
        .ok_or_else(|| Error::Catalog(format!("bad {what} '{text}'")))
}

fn optional_value(
    text: &Option<String>,
    dtype: DataType,
    address: Address,
    what: &str,
) -> Result<Option<Value>, Error> {
    text.as_deref()
        .map(|t| {
            Value::parse(dtype, t).map_err(|e| Error::Catalog(format!("{address} {what}: {e}")))
        })
        .transpose()
}

impl ObjectDef {
    fn add_to(mut self, catalog: &mut Catalog) -> Result<(), Error> {
        let index = parse_hex_u32(&self.index, "index", 0xFFFF)? as u16;
        if self.subs.is_empty() {
            let entry = self.variable(index)?;
            if catalog.entries.contains_key(&entry.address) {
                return Err(self.error(index, "defined twice"));
            }
            catalog.insert(entry);
            return Ok(());
        }
        if self.dtype.is_some() || self.access.is_some() || self.default.is_some() {
            return Err(self.error(
                index,
                "an object with subindices takes type, access and default per subindex",
            ));
        }
        for sub in std::mem::take(&mut self.subs) {
            let entry = self.sub_entry(index, sub)?;
            if catalog.entries.contains_key(&entry.address) {
                return Err(Error::Catalog(format!("{} defined twice", entry.address)));
            }
            catalog.insert(entry);
        }
        Ok(())
    }

    /// A problem with this object of the catalog file.
    fn error(&self, index: u16, msg: &str) -> Error {
        Error::Catalog(format!("object {:04X}h {}: {msg}", index, self.name))
    }

    /// The entry of an object without subindices (a variable, at sub 0).
    fn variable(&self, index: u16) -> Result<Entry, Error> {
        let dtype = self
            .dtype
            .ok_or_else(|| self.error(index, "a variable needs a type"))?;
        let access = self
            .access
            .ok_or_else(|| self.error(index, "a variable needs an access"))?;
        let address = Address::new(index, 0);
        Ok(Entry {
            address,
            object_name: self.name.clone(),
            name: self.name.clone(),
            dtype,
            access,
            unit: self.unit.clone(),
            description: self.description.clone(),
            default: optional_value(&self.default, dtype, address, "default")?,
            min: optional_value(&self.min, dtype, address, "min")?,
            max: optional_value(&self.max, dtype, address, "max")?,
            group: Group::of_index(index),
            role: Role::of(address, access, dtype),
            bits: bit_names(&self.bits, dtype, address)?,
        })
    }

    /// The entry of one subindex; unit, description and limits it leaves out are the
    /// object's.
    fn sub_entry(&self, index: u16, sub: SubDef) -> Result<Entry, Error> {
        let address = Address::new(index, parse_hex_u32(&sub.sub, "subindex", 0xFF)? as u8);
        let min = sub.min.or_else(|| self.min.clone());
        let max = sub.max.or_else(|| self.max.clone());
        Ok(Entry {
            address,
            object_name: self.name.clone(),
            name: sub.name,
            dtype: sub.dtype,
            access: sub.access,
            unit: sub.unit.or_else(|| self.unit.clone()),
            description: if sub.description.is_empty() {
                self.description.clone()
            } else {
                sub.description
            },
            default: optional_value(&sub.default, sub.dtype, address, "default")?,
            min: optional_value(&min, sub.dtype, address, "min")?,
            max: optional_value(&max, sub.dtype, address, "max")?,
            group: Group::of_index(index),
            role: Role::of(address, sub.access, sub.dtype),
            bits: bit_names(&sub.bits, sub.dtype, address)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_catalog_loads() {
        let catalog = Catalog::builtin().unwrap();
        assert!(catalog.len() > 50, "{}", catalog.len());
        let vendor = catalog.get(Address::new(0x1018, 1)).unwrap();
        assert_eq!(vendor.dtype, DataType::Unsigned32);
        assert_eq!(vendor.default, Some(Value::Uint(0x26C)));
        assert_eq!(vendor.group, Group::Communication);
        assert!(catalog.has_index(0x2291));
    }

    #[test]
    fn malformed_catalogs_say_where() {
        let err = Catalog::from_json(
            r#"{"objects":[{"index":"6064","name":"Position","type":"INTEGER32"}]}"#,
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "catalog: object 6064h Position: a variable needs an access"
        );
        let err = Catalog::from_json(
            r#"{"objects":[{"index":"6064","name":"P","type":"INTEGER8","access":"rw","default":"300"}]}"#,
        )
        .unwrap_err();
        assert!(err.to_string().contains("6064h:00h default"), "{err}");
        assert!(Catalog::from_json("{").is_err());
        let err = Catalog::from_json(
            r#"{"objects":[{"index":"1001","name":"E","type":"UNSIGNED8","access":"ro","bits":{"8":"past the end"}}]}"#,
        )
        .unwrap_err();
        assert!(
            err.to_string()
                .contains("1001h:00h bit '8': not a bit of a U8 (8 bits)"),
            "{err}"
        );
    }

    #[test]
    fn words_name_their_bits_in_order() {
        let catalog = Catalog::builtin().unwrap();
        let status = catalog.get(Address::new(0x6041, 0)).unwrap();
        assert_eq!(status.bits.first(), Some(&(0, "ready to switch on".into())));
        assert!(status.bits.windows(2).all(|w| w[0].0 < w[1].0));
        let inputs = catalog.get(Address::new(0x60FD, 0)).unwrap();
        assert_eq!(inputs.bits[1], (1, "positive limit switch".into()));
        assert!(
            catalog
                .get(Address::new(0x6064, 0))
                .unwrap()
                .bits
                .is_empty()
        );
    }

    #[test]
    fn limits_are_checked() {
        let catalog = Catalog::from_json(
            r#"{"objects":[{"index":"605A","name":"Quick Stop Option Code","type":"INTEGER16","access":"rw","min":"0","max":"6"}]}"#,
        )
        .unwrap();
        let entry = catalog.get(Address::new(0x605A, 0)).unwrap();
        assert!(entry.check(&Value::Int(6)).is_ok());
        assert_eq!(
            entry.check(&Value::Int(7)),
            Err(Error::TooHigh {
                value: "7".into(),
                max: "6".into()
            })
        );
        assert!(entry.check(&Value::Int(-1)).is_err());
        assert!(entry.check(&Value::Int(70000)).is_err());
    }

    #[test]
    fn filter_finds_by_name_and_index() {
        let catalog = Catalog::builtin().unwrap();
        assert!(
            catalog
                .filter("vendor")
                .any(|e| e.address == Address::new(0x1018, 1))
        );
        assert!(catalog.filter("6064").any(|e| e.address.index == 0x6064));
        assert!(
            catalog
                .filter("1018:01")
                .any(|e| e.address == Address::new(0x1018, 1))
        );
        let addresses =
            |f: &str| -> Vec<Address> { catalog.filter(f).map(|e| e.address).collect() };
        for exact in ["1018:01", "1018h:1h", "0x1018.1", "1018/01"] {
            assert_eq!(addresses(exact), vec![Address::new(0x1018, 1)], "{exact}");
        }
        assert_eq!(addresses("6064"), vec![Address::new(0x6064, 0)]);
        assert_eq!(addresses("6064h"), vec![Address::new(0x6064, 0)]);
        assert_eq!(addresses("1018:").len(), 5);
        // A prefix of the index, not any part of the address: 60 is 60xxh, never 1600h.
        let sixty = addresses("60");
        assert!(sixty.contains(&Address::new(0x6040, 0)));
        assert!(sixty.iter().all(|a| a.index >> 8 == 0x60), "{sixty:?}");
        assert!(addresses("nominal").contains(&Address::new(0x203B, 1)));
        assert_eq!(catalog.filter("").count(), catalog.len());
    }
}
