//! What a user asks the drive to do, with its set values checked against their real widths
//! (spec 2.1.2: SetValue1 SIGNED32, SetValue2 SIGNED16, SetValue3 SIGNED08).

use std::fmt;

use super::{Error, Opcode};

/// The three set-value entries of 2291h.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Field {
    SetValue1,
    SetValue2,
    SetValue3,
}

impl Field {
    pub fn name(self) -> &'static str {
        match self {
            Field::SetValue1 => "PDI-SetValue1",
            Field::SetValue2 => "PDI-SetValue2",
            Field::SetValue3 => "PDI-SetValue3",
        }
    }

    pub fn object(self) -> &'static str {
        match self {
            Field::SetValue1 => "2291h:01h",
            Field::SetValue2 => "2291h:02h",
            Field::SetValue3 => "2291h:03h",
        }
    }

    /// The range of the SIGNED field itself.
    pub fn raw_range(self) -> (i64, i64) {
        match self {
            Field::SetValue1 => (i64::from(i32::MIN), i64::from(i32::MAX)),
            Field::SetValue2 => (i64::from(i16::MIN), i64::from(i16::MAX)),
            Field::SetValue3 => (i64::from(i8::MIN), i64::from(i8::MAX)),
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.name(), self.object())
    }
}

/// How a field's number is written and read by a person.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Radix {
    Decimal,
    /// OD indices and subindices: shown and typed in hex.
    Hex,
}

/// One input of a command: which set value it travels in, what it means, its unit and the
/// range a user may type. The range is what the field can carry (OD indices and
/// subindices are unsigned to the user and travel as two's complement).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldSpec {
    pub field: Field,
    pub label: &'static str,
    pub unit: &'static str,
    pub min: i64,
    pub max: i64,
    pub radix: Radix,
    /// Extra advice shown with a range error.
    pub hint: &'static str,
}

impl FieldSpec {
    const fn new(field: Field, label: &'static str, unit: &'static str) -> Self {
        let (min, max) = match field {
            Field::SetValue1 => (i32::MIN as i64, i32::MAX as i64),
            Field::SetValue2 => (i16::MIN as i64, i16::MAX as i64),
            Field::SetValue3 => (i8::MIN as i64, i8::MAX as i64),
        };
        Self {
            field,
            label,
            unit,
            min,
            max,
            radix: Radix::Decimal,
            hint: "",
        }
    }

    const fn range(mut self, min: i64, max: i64) -> Self {
        self.min = min;
        self.max = max;
        self
    }

    const fn hex(mut self) -> Self {
        self.radix = Radix::Hex;
        self
    }

    const fn hint(mut self, hint: &'static str) -> Self {
        self.hint = hint;
        self
    }

    /// Check a typed value against the range; the error names field, value and range.
    pub fn check(&self, value: i64) -> Result<i64, Error> {
        if value < self.min || value > self.max {
            return Err(Error::OutOfRange {
                field: self.field,
                label: self.label,
                value,
                min: self.min,
                max: self.max,
                hint: self.hint,
            });
        }
        Ok(value)
    }

    /// Parse what a user typed (decimal, or hex with `0x`/`h` for hex fields) and check it.
    pub fn parse(&self, text: &str) -> Result<i64, Error> {
        let value = parse_number(text, self.radix).ok_or_else(|| Error::NotANumber {
            label: self.label,
            text: text.trim().to_owned(),
            radix: self.radix,
        })?;
        self.check(value)
    }

    /// Format a value for an input box.
    pub fn format(&self, value: i64) -> String {
        match self.radix {
            Radix::Decimal => value.to_string(),
            Radix::Hex => format!("{value:X}"),
        }
    }
}

/// Parse a number typed by a person (see [`crate::number::parse_integer`]); hex fields
/// take plain hex digits.
pub fn parse_number(text: &str, radix: Radix) -> Option<i64> {
    crate::number::parse_integer(text, radix == Radix::Hex).and_then(|v| i64::try_from(v).ok())
}

const POSITION: FieldSpec = FieldSpec::new(Field::SetValue1, "Target position", "0.1°");
const DISTANCE: FieldSpec = FieldSpec::new(Field::SetValue1, "Distance", "0.1°");
const MAX_SPEED: FieldSpec = FieldSpec::new(Field::SetValue2, "Max speed", "rpm").hint(
    "PDI-SetValue2 is 16 bits wide; choose a coarser speed unit (user-defined units) for higher speeds",
);
const VELOCITY: FieldSpec = FieldSpec::new(Field::SetValue1, "Target speed", "rpm");
const TORQUE: FieldSpec = FieldSpec::new(Field::SetValue1, "Target torque", "‰")
    .hint("Thousandths of the motor's rated torque (6076h)");
const HOME_POSITION: FieldSpec = FieldSpec::new(Field::SetValue1, "Actual position", "0.1°");
const HOMING_METHOD: FieldSpec = FieldSpec::new(Field::SetValue3, "Homing method", "");
const OD_INDEX: FieldSpec = FieldSpec::new(Field::SetValue2, "Index", "hex")
    .range(0, 0xFFFF)
    .hex();
const OD_SUBINDEX: FieldSpec = FieldSpec::new(Field::SetValue3, "Subindex", "hex")
    .range(0, 0xFF)
    .hex();
const OD_VALUE: FieldSpec = FieldSpec::new(Field::SetValue1, "Value", "")
    .range(i32::MIN as i64, u32::MAX as i64)
    .hint("PDI-SetValue1 is 32 bits wide: -2147483648 to 4294967295 (unsigned values travel as two's complement)");

impl Opcode {
    /// The inputs a user gives for this command, in the order they are asked for.
    pub fn fields(self) -> &'static [FieldSpec] {
        match self {
            Opcode::Nop
            | Opcode::SwitchOff
            | Opcode::ClearError
            | Opcode::Quickstop
            | Opcode::AutoSetup => &[],
            Opcode::OdRead => &[OD_INDEX, OD_SUBINDEX],
            Opcode::OdWrite => &[OD_INDEX, OD_SUBINDEX, OD_VALUE],
            Opcode::HomeHere => &[HOME_POSITION],
            Opcode::Homing => &[HOMING_METHOD],
            Opcode::MoveAbsolute => &[POSITION, MAX_SPEED],
            Opcode::MoveRelative => &[DISTANCE, MAX_SPEED],
            Opcode::Velocity => &[VELOCITY],
            Opcode::Torque => &[TORQUE, MAX_SPEED],
        }
    }
}

/// The raw set values of one RX image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SetValues {
    pub value1: i32,
    pub value2: i16,
    pub value3: i8,
}

/// An OD address as the PDI carries it in SetValue2/SetValue3: two's complement for
/// indices ≥ 8000h and subindices ≥ 80h, both ways (PDI spec §2.1.2, protocol notes §5.10).
pub fn index_to_set_value2(index: u16) -> i16 {
    index as i16
}

pub fn set_value2_to_index(value: i16) -> u16 {
    value as u16
}

pub fn subindex_to_set_value3(sub: u8) -> i8 {
    sub as i8
}

pub fn set_value3_to_subindex(value: i8) -> u8 {
    value as u8
}

/// One PDI command with its set values, each already within its width.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    Nop,
    SwitchOff,
    ClearError,
    Quickstop,
    OdRead {
        index: u16,
        sub: u8,
    },
    /// `value` is the raw SIGNED32 of PDI-SetValue1 (unsigned objects as two's complement).
    OdWrite {
        index: u16,
        sub: u8,
        value: i32,
    },
    AutoSetup,
    HomeHere {
        position: i32,
    },
    Homing {
        method: i8,
    },
    MoveAbsolute {
        target: i32,
        speed: i16,
    },
    MoveRelative {
        distance: i32,
        speed: i16,
    },
    Velocity {
        speed: i32,
    },
    Torque {
        torque: i32,
        max_speed: i16,
    },
}

impl Action {
    pub fn opcode(&self) -> Opcode {
        match self {
            Action::Nop => Opcode::Nop,
            Action::SwitchOff => Opcode::SwitchOff,
            Action::ClearError => Opcode::ClearError,
            Action::Quickstop => Opcode::Quickstop,
            Action::OdRead { .. } => Opcode::OdRead,
            Action::OdWrite { .. } => Opcode::OdWrite,
            Action::AutoSetup => Opcode::AutoSetup,
            Action::HomeHere { .. } => Opcode::HomeHere,
            Action::Homing { .. } => Opcode::Homing,
            Action::MoveAbsolute { .. } => Opcode::MoveAbsolute,
            Action::MoveRelative { .. } => Opcode::MoveRelative,
            Action::Velocity { .. } => Opcode::Velocity,
            Action::Torque { .. } => Opcode::Torque,
        }
    }

    /// The set values this command writes. Commands without inputs write zeros.
    pub fn set_values(&self) -> SetValues {
        let mut v = SetValues::default();
        match *self {
            Action::Nop
            | Action::SwitchOff
            | Action::ClearError
            | Action::Quickstop
            | Action::AutoSetup => {}
            Action::OdRead { index, sub } => {
                v.value2 = index_to_set_value2(index);
                v.value3 = subindex_to_set_value3(sub);
            }
            Action::OdWrite { index, sub, value } => {
                v.value1 = value;
                v.value2 = index_to_set_value2(index);
                v.value3 = subindex_to_set_value3(sub);
            }
            Action::HomeHere { position } => v.value1 = position,
            Action::Homing { method } => v.value3 = method,
            Action::MoveAbsolute { target, speed } => {
                v.value1 = target;
                v.value2 = speed;
            }
            Action::MoveRelative { distance, speed } => {
                v.value1 = distance;
                v.value2 = speed;
            }
            Action::Velocity { speed } => v.value1 = speed,
            Action::Torque { torque, max_speed } => {
                v.value1 = torque;
                v.value2 = max_speed;
            }
        }
        v
    }

    /// Build a command from the values a user typed, in the order of `opcode.fields()`.
    /// Every value is range-checked; the first one that does not fit is the error.
    pub fn from_inputs(opcode: Opcode, inputs: &[i64]) -> Result<Action, Error> {
        let specs = opcode.fields();
        if inputs.len() != specs.len() {
            return Err(Error::WrongInputCount {
                opcode,
                expected: specs.len(),
                got: inputs.len(),
            });
        }
        // Each value goes to its field; the check bounds it to the field's width (or, for
        // an unsigned OD value, to its 32 bits), so the narrowing below is exact.
        let mut values = SetValues::default();
        for (spec, value) in specs.iter().zip(inputs) {
            let value = spec.check(*value)?;
            match spec.field {
                Field::SetValue1 => values.value1 = value as i32,
                Field::SetValue2 => values.value2 = value as i16,
                Field::SetValue3 => values.value3 = value as i8,
            }
        }
        Ok(Action::from_set_values(opcode, values))
    }

    /// The command an RX image describes (the inverse of `set_values`).
    pub fn from_set_values(opcode: Opcode, v: SetValues) -> Action {
        let index = set_value2_to_index(v.value2);
        let sub = set_value3_to_subindex(v.value3);
        match opcode {
            Opcode::Nop => Action::Nop,
            Opcode::SwitchOff => Action::SwitchOff,
            Opcode::ClearError => Action::ClearError,
            Opcode::Quickstop => Action::Quickstop,
            Opcode::AutoSetup => Action::AutoSetup,
            Opcode::OdRead => Action::OdRead { index, sub },
            Opcode::OdWrite => Action::OdWrite {
                index,
                sub,
                value: v.value1,
            },
            Opcode::HomeHere => Action::HomeHere { position: v.value1 },
            Opcode::Homing => Action::Homing { method: v.value3 },
            Opcode::MoveAbsolute => Action::MoveAbsolute {
                target: v.value1,
                speed: v.value2,
            },
            Opcode::MoveRelative => Action::MoveRelative {
                distance: v.value1,
                speed: v.value2,
            },
            Opcode::Velocity => Action::Velocity { speed: v.value1 },
            Opcode::Torque => Action::Torque {
                torque: v.value1,
                max_speed: v.value2,
            },
        }
    }

    /// The values as a user would type them back, in the order of `opcode.fields()`.
    pub fn inputs(&self) -> Vec<i64> {
        match *self {
            Action::Nop
            | Action::SwitchOff
            | Action::ClearError
            | Action::Quickstop
            | Action::AutoSetup => vec![],
            Action::OdRead { index, sub } => vec![index.into(), sub.into()],
            Action::OdWrite { index, sub, value } => {
                vec![index.into(), sub.into(), value.into()]
            }
            Action::HomeHere { position } => vec![position.into()],
            Action::Homing { method } => vec![method.into()],
            Action::MoveAbsolute { target, speed } => vec![target.into(), speed.into()],
            Action::MoveRelative { distance, speed } => vec![distance.into(), speed.into()],
            Action::Velocity { speed } => vec![speed.into()],
            Action::Torque { torque, max_speed } => vec![torque.into(), max_speed.into()],
        }
    }
}

impl fmt::Display for Action {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let op = self.opcode();
        f.write_str(op.name())?;
        let specs = op.fields();
        if specs.is_empty() {
            return Ok(());
        }
        let parts: Vec<String> = specs
            .iter()
            .zip(self.inputs())
            .map(|(spec, value)| {
                let shown = match spec.radix {
                    Radix::Decimal => value.to_string(),
                    Radix::Hex => format!("{value:X}h"),
                };
                if spec.unit.is_empty() || spec.radix == Radix::Hex {
                    format!("{} {shown}", spec.label.to_lowercase())
                } else {
                    format!("{} {shown} {}", spec.label.to_lowercase(), spec.unit)
                }
            })
            .collect();
        write!(f, ": {}", parts.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_value2_out_of_range_names_field_value_and_range() {
        let err = Action::from_inputs(Opcode::MoveAbsolute, &[2000, 40000]).unwrap_err();
        assert_eq!(
            err,
            Error::OutOfRange {
                field: Field::SetValue2,
                label: "Max speed",
                value: 40000,
                min: -32768,
                max: 32767,
                hint: MAX_SPEED.hint,
            }
        );
        let text = err.to_string();
        assert!(text.contains("PDI-SetValue2"), "{text}");
        assert!(text.contains("40000"), "{text}");
        assert!(text.contains("-32 768 … 32 767"), "{text}");
        assert!(text.contains("speed unit"), "{text}");
    }

    #[test]
    fn set_value1_and_3_widths_are_enforced() {
        assert!(Action::from_inputs(Opcode::Velocity, &[i64::from(i32::MAX)]).is_ok());
        assert!(matches!(
            Action::from_inputs(Opcode::Velocity, &[i64::from(i32::MAX) + 1]),
            Err(Error::OutOfRange {
                field: Field::SetValue1,
                ..
            })
        ));
        assert!(matches!(
            Action::from_inputs(Opcode::Homing, &[128]),
            Err(Error::OutOfRange {
                field: Field::SetValue3,
                max: 127,
                ..
            })
        ));
        assert_eq!(
            Action::from_inputs(Opcode::Homing, &[-1]),
            Ok(Action::Homing { method: -1 })
        );
    }

    #[test]
    fn high_indices_travel_as_twos_complement_both_ways() {
        let action = Action::from_inputs(Opcode::OdRead, &[0xA000, 0x80]).unwrap();
        let v = action.set_values();
        assert_eq!(v.value2, -24576); // A000h as SIGNED16
        assert_eq!(v.value3, -128); // 80h as SIGNED08
        assert_eq!(set_value2_to_index(v.value2), 0xA000);
        assert_eq!(set_value3_to_subindex(v.value3), 0x80);
        for index in [0u16, 0x1000, 0x7FFF, 0x8000, 0xFFFF] {
            assert_eq!(set_value2_to_index(index_to_set_value2(index)), index);
        }
        for sub in 0u8..=255 {
            assert_eq!(set_value3_to_subindex(subindex_to_set_value3(sub)), sub);
        }
        assert!(Action::from_inputs(Opcode::OdRead, &[0x1_0000, 0]).is_err());
        assert!(Action::from_inputs(Opcode::OdRead, &[0x1000, 0x100]).is_err());
    }

    #[test]
    fn od_write_accepts_unsigned_32_bit_values() {
        let action = Action::from_inputs(Opcode::OdWrite, &[0x1010, 1, 0x6576_6173]).unwrap();
        assert_eq!(action.set_values().value1, 0x6576_6173);
        let action = Action::from_inputs(Opcode::OdWrite, &[0x60FE, 1, 0xFFFF_FFFF]).unwrap();
        assert_eq!(action.set_values().value1, -1);
        assert!(Action::from_inputs(Opcode::OdWrite, &[0x60FE, 1, 0x1_0000_0000]).is_err());
    }

    #[test]
    fn wrong_input_count_is_an_error() {
        assert_eq!(
            Action::from_inputs(Opcode::MoveAbsolute, &[1]),
            Err(Error::WrongInputCount {
                opcode: Opcode::MoveAbsolute,
                expected: 2,
                got: 1
            })
        );
    }

    #[test]
    fn inputs_round_trip_for_every_opcode() {
        for op in Opcode::ALL {
            let inputs: Vec<i64> = op.fields().iter().map(|s| s.max).collect();
            let action = Action::from_inputs(op, &inputs).unwrap();
            assert_eq!(action.opcode(), op);
            let back: Vec<i64> = action
                .inputs()
                .into_iter()
                .zip(op.fields())
                .map(|(v, s)| {
                    if s.max == i64::from(u32::MAX) {
                        i64::from(v as u32)
                    } else {
                        v
                    }
                })
                .collect();
            assert_eq!(back, inputs, "{op:?}");
        }
    }

    #[test]
    fn set_values_round_trip_for_every_opcode() {
        for op in Opcode::ALL {
            let inputs: Vec<i64> = op.fields().iter().map(|s| s.min.max(-7)).collect();
            let action = Action::from_inputs(op, &inputs).unwrap();
            assert_eq!(Action::from_set_values(op, action.set_values()), action);
        }
    }

    #[test]
    fn typed_numbers_parse() {
        assert_eq!(parse_number("2000", Radix::Decimal), Some(2000));
        assert_eq!(parse_number(" -5 ", Radix::Decimal), Some(-5));
        assert_eq!(parse_number("0x1F", Radix::Decimal), Some(31));
        assert_eq!(parse_number("203Bh", Radix::Decimal), Some(0x203B));
        assert_eq!(parse_number("203B", Radix::Hex), Some(0x203B));
        assert_eq!(parse_number("1_000", Radix::Decimal), Some(1000));
        assert_eq!(parse_number("", Radix::Decimal), None);
        assert_eq!(parse_number("-", Radix::Decimal), None);
        assert_eq!(parse_number("12a", Radix::Decimal), None);
        let spec = &Opcode::OdRead.fields()[0];
        assert!(matches!(spec.parse("zz"), Err(Error::NotANumber { .. })));
        assert_eq!(spec.parse("3320"), Ok(0x3320));
    }

    #[test]
    fn display_reads_like_the_spec() {
        let action = Action::MoveAbsolute {
            target: 2000,
            speed: 200,
        };
        assert_eq!(
            action.to_string(),
            "Profile Position absolute: target position 2000 0.1°, max speed 200 rpm"
        );
        assert_eq!(
            Action::OdRead {
                index: 0x3320,
                sub: 1
            }
            .to_string(),
            "OD-Read: index 3320h, subindex 1h"
        );
    }
}
