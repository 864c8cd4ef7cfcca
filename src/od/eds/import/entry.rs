//! One VAR or sub-index section into a catalog [`Entry`] and its [`EntryInfo`]: DataType,
//! AccessType, PDOMapping, DefaultValue and the limits, each read past with a warning
//! where it is wrong.

use super::Importer;
use crate::od::eds::ini::{Section, clip};
use crate::od::eds::values::{TypeUse, parse_int, parse_value, type_name};
use crate::od::eds::{EdsAccess, EntryInfo, NodeFormula};
use crate::od::{Address, DataType, Entry, Group, Role, Value};

/// What a value key gave: the value (if it is known) and the formula (if it is one).
type Read = (Option<Value>, Option<NodeFormula>);

impl Importer<'_> {
    /// One entry from a VAR or sub-index section.
    pub(super) fn read_entry(
        &mut self,
        s: &Section,
        address: Address,
        object_name: &str,
        name: String,
        domain_object: bool,
    ) -> (Entry, EntryInfo) {
        let at = format!("{address}");
        let code = self.data_type(s, &at, domain_object);
        let ty = TypeUse::of(code);
        self.check_type_use(s, &at, ty, code);
        let access = self.access_type(s, &at);
        let pdo_mapping = self.pdo_mapping(s, &at);
        let dtype = ty.dtype();
        let (default, default_formula) = self.value(s, &at, "DefaultValue", ty, code);
        let ((min, low_formula), (max, high_formula)) = self.limits(s, &at, ty, code);
        let entry = Entry {
            address,
            object_name: object_name.to_owned(),
            name: if name.is_empty() {
                object_name.to_owned()
            } else {
                name
            },
            dtype,
            access: access.access(),
            unit: s.text("Unit").map(str::to_owned),
            description: s.text("Description").unwrap_or_default().to_owned(),
            default,
            min,
            max,
            group: Group::of_index(address.index),
            role: Role::of_eds(
                address,
                access.access(),
                dtype,
                matches!(access, EdsAccess::Rww | EdsAccess::Rwr),
            ),
            // Bit names are the profile's (CiA 301/402), not the EDS's: borrowed from the
            // built-in catalog where it names the same object with the same type.
            bits: crate::od::builtin()
                .get(address)
                .filter(|known| known.dtype == dtype)
                .map(|known| known.bits.clone())
                .unwrap_or_default(),
        };
        self.check_default(s, &at, &entry);
        let info = EntryInfo {
            type_code: code,
            access,
            pdo_mapping,
            default_formula,
            low_formula,
            high_formula,
        };
        (entry, info)
    }

    /// A warning where the default is outside the entry's limits or type; it is kept.
    fn check_default(&mut self, s: &Section, at: &str, entry: &Entry) {
        if let Some(default) = &entry.default
            && let Err(e) = entry.check(default)
        {
            self.warn(
                s.line_of("DefaultValue"),
                format!("{at}: DefaultValue {e} (kept)"),
            );
        }
    }

    /// DataType as a code; DOMAIN where it is missing or no code.
    fn data_type(&mut self, s: &Section, at: &str, domain_object: bool) -> u16 {
        match s.text("DataType") {
            Some(text) => match parse_int(text).filter(|v| (0..=0xFFFF).contains(&v.value)) {
                Some(v) => v.value as u16,
                None => {
                    let message = format!(
                        "{at}: DataType='{}' is not a type code; kept as DOMAIN (raw bytes)",
                        clip(text)
                    );
                    self.warn(s.line_of("DataType"), message);
                    DataType::Domain.code()
                }
            },
            None if domain_object => DataType::Domain.code(),
            None => {
                self.warn(
                    s.line,
                    format!("{at} has no DataType: kept as DOMAIN (raw bytes)"),
                );
                DataType::Domain.code()
            }
        }
    }

    /// A warning where the type is kept as DOMAIN.
    fn check_type_use(&mut self, s: &Section, at: &str, ty: TypeUse, code: u16) {
        let message = match ty {
            TypeUse::Native(_) => return,
            TypeUse::OddInteger { bits, .. } => format!(
                "{at}: drivedeck has no {bits}-bit type for {}: \
                 kept as DOMAIN (its little-endian bytes)",
                type_name(code)
            ),
            TypeUse::Opaque => format!(
                "{at}: {} is not a CANopen basic type drivedeck knows: \
                 kept as DOMAIN (raw bytes), without default or limits",
                type_name(code)
            ),
        };
        self.warn(s.line_of("DataType"), message);
    }

    /// AccessType; a guess from words like `read`, else ro, where it is none of CiA 306's.
    fn access_type(&mut self, s: &Section, at: &str) -> EdsAccess {
        let Some(text) = s.text("AccessType") else {
            self.warn(s.line, format!("{at} has no AccessType: read as ro"));
            return EdsAccess::Ro;
        };
        if let Some(access) = EdsAccess::parse(text) {
            return access;
        }
        let guess = match text.trim().to_ascii_lowercase().as_str() {
            "r" | "read" | "readonly" => EdsAccess::Ro,
            "w" | "write" | "writeonly" => EdsAccess::Wo,
            "readwrite" | "r/w" => EdsAccess::Rw,
            _ => EdsAccess::Ro,
        };
        let message = format!(
            "{at}: AccessType='{}' is not ro, wo, rw, rwr, rww or const: read as {}",
            clip(text),
            guess.as_str()
        );
        self.warn(s.line_of("AccessType"), message);
        guess
    }

    /// PDOMapping: 0 or 1; 0 where not given or anything else.
    fn pdo_mapping(&mut self, s: &Section, at: &str) -> bool {
        let Some(text) = s.text("PDOMapping") else {
            return false;
        };
        match parse_int(text) {
            Some(v) if v.value == 0 || v.value == 1 => v.value == 1,
            _ => {
                self.warn(
                    s.line_of("PDOMapping"),
                    format!("{at}: PDOMapping='{}' is not 0 or 1: read as 0", clip(text)),
                );
                false
            }
        }
    }

    /// LowLimit and HighLimit; neither where low is above high.
    fn limits(&mut self, s: &Section, at: &str, ty: TypeUse, code: u16) -> (Read, Read) {
        let low = self.value(s, at, "LowLimit", ty, code);
        let high = self.value(s, at, "HighLimit", ty, code);
        if let (Some(lo), Some(hi)) = (
            low.0.as_ref().and_then(Value::as_f64),
            high.0.as_ref().and_then(Value::as_f64),
        ) && lo > hi
        {
            self.warn(
                s.line_of("LowLimit"),
                format!("{at}: LowLimit {lo} is above HighLimit {hi}; both ignored"),
            );
            return ((None, None), (None, None));
        }
        (low, high)
    }

    /// The value of a key for the entry's type. Strings and bytes have no limits.
    fn value(&mut self, s: &Section, at: &str, key: &str, ty: TypeUse, code: u16) -> Read {
        let Some(text) = s.text(key) else {
            return (None, None);
        };
        if ty == TypeUse::Opaque {
            return (None, None);
        }
        if matches!(
            ty,
            TypeUse::Native(
                DataType::VisibleString
                    | DataType::UnicodeString
                    | DataType::OctetString
                    | DataType::Domain
            )
        ) && key != "DefaultValue"
        {
            self.warn(
                s.line_of(key),
                format!(
                    "{at}: {key} does not apply to a {}; ignored",
                    ty.dtype().short_name()
                ),
            );
            return (None, None);
        }
        match parse_value(text, ty, code, self.node_id) {
            Ok(parsed) => {
                if parsed.octal {
                    self.warn(
                        s.line_of(key),
                        format!(
                            "{at}: {key}={text} has a leading 0: read as octal {} (CiA 306); write it without the 0 for decimal",
                            parsed.value.as_ref().map(Value::to_string).unwrap_or_default()
                        ),
                    );
                }
                (parsed.value, parsed.formula)
            }
            Err(e) => {
                self.warn(s.line_of(key), format!("{at}: {key}: {e}; ignored"));
                (None, None)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::od::eds::testing::parse;
    use crate::od::{Access, Address, Value};

    #[test]
    fn odd_but_readable_files() {
        let text = "\u{FEFF}[DeviceInfo]\nVendorNumber=1\n\
[OptionalObjects]\nSupportedObjects=2\n1=0x2000\n3=0x2001\n\
[2000]\nParameterName=Flag\nDataType=1\nAccessType=RW\nDefaultValue=true\n\
[2001]\nParameterName=Octal\nDataType=0x0005\nAccessType=Read\nDefaultValue=010\nLowLimit=9\nHighLimit=2\n\
[2002]\nParameterName=Outside\nDataType=0x0005\nAccessType=ro\nDefaultValue=7\nHighLimit=6\n";
        let eds = parse(text);
        let get = |i: u16| eds.catalog.get(Address::new(i, 0)).unwrap();
        assert_eq!(get(0x2000).default, Some(Value::Bool(true)));
        assert_eq!(get(0x2001).default, Some(Value::Uint(8)));
        assert_eq!(get(0x2001).access, Access::Ro);
        assert_eq!((&get(0x2001).min, &get(0x2001).max), (&None, &None));
        assert_eq!(get(0x2002).default, Some(Value::Uint(7)));
        let messages: Vec<String> = eds.warnings.iter().map(ToString::to_string).collect();
        assert_eq!(
            messages,
            [
                "line 15: 2001h:00h: AccessType='Read' is not ro, wo, rw, rwr, rww or const: read as ro",
                "line 16: 2001h:00h: DefaultValue=010 has a leading 0: read as octal 8 (CiA 306); write it without the 0 for decimal",
                "line 17: 2001h:00h: LowLimit 9 is above HighLimit 2; both ignored",
                "line 19: 2002h have sections but no [MandatoryObjects], [OptionalObjects] or [ManufacturerObjects] entry: imported anyway",
                "line 23: 2002h:00h: DefaultValue 7 is above the object's maximum 6 (kept)",
            ]
        );
    }
}
