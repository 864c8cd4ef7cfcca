//! PDI-Cmd (2291h:04h): the opcode in bits 0-5, the halt bit 6 and the ToggleCmd bit 7
//! (spec section 2.2).

use std::fmt;

use super::Error;

/// What PDI-ReturnValue holds after a command ([`Opcode::return_value`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReturnValue {
    /// The actual position (0.1° in the drive's user units by default).
    Position,
    /// The actual speed (rpm).
    Velocity,
    /// The actual torque (‰ of the rated torque).
    Torque,
    /// The value of the object read.
    ObjectRead,
    /// The spec does not say.
    NotSpecified,
}

enum_with_all! {
    /// The 13 PDI commands of spec section 2.2.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum Opcode {
        Nop = 0,
        SwitchOff = 1,
        ClearError = 2,
        Quickstop = 3,
        OdRead = 14,
        OdWrite = 15,
        AutoSetup = 16,
        HomeHere = 17,
        Homing = 18,
        MoveAbsolute = 20,
        MoveRelative = 21,
        Velocity = 23,
        Torque = 25,
    }
}

impl Opcode {
    pub fn value(self) -> u8 {
        self as u8
    }

    pub fn from_value(value: u8) -> Result<Self, Error> {
        Opcode::ALL
            .into_iter()
            .find(|op| op.value() == value)
            .ok_or(Error::UnknownOpcode(value))
    }

    /// The command's name as the spec writes it.
    pub fn name(self) -> &'static str {
        match self {
            Opcode::Nop => "NOP",
            Opcode::SwitchOff => "Switch Off",
            Opcode::ClearError => "Clear Error",
            Opcode::Quickstop => "Quickstop",
            Opcode::OdRead => "OD-Read",
            Opcode::OdWrite => "OD-Write",
            Opcode::AutoSetup => "Auto setup",
            Opcode::HomeHere => "Homing on current position",
            Opcode::Homing => "Homing",
            Opcode::MoveAbsolute => "Profile Position absolute",
            Opcode::MoveRelative => "Profile Position relative",
            Opcode::Velocity => "Profile Velocity",
            Opcode::Torque => "Profile Torque",
        }
    }

    /// What PDI-ReturnValue holds while this is the last command sent, as spec section 2.2
    /// says: the position for the Profile Position commands (2.2.10, 2.2.11), the speed for
    /// Profile Velocity (2.2.12), the torque for Profile Torque (2.2.13), the object's value
    /// for OD-Read (2.2.5). For the others the spec is silent (an error code after a
    /// refusal aside, which PdiStatusError marks).
    pub fn return_value(self) -> ReturnValue {
        match self {
            Opcode::MoveAbsolute | Opcode::MoveRelative => ReturnValue::Position,
            Opcode::Velocity => ReturnValue::Velocity,
            Opcode::Torque => ReturnValue::Torque,
            Opcode::OdRead => ReturnValue::ObjectRead,
            _ => ReturnValue::NotSpecified,
        }
    }

    /// The travel commands, the only ones the halt bit applies to (spec 2.2.14).
    pub fn is_travel(self) -> bool {
        matches!(
            self,
            Opcode::MoveAbsolute | Opcode::MoveRelative | Opcode::Velocity | Opcode::Torque
        )
    }

    /// Commands that energise the power stage (spec 2.2.2 tip: any travel command, and
    /// homing and auto setup which move the motor).
    pub fn energises(self) -> bool {
        self.is_travel() || matches!(self, Opcode::Homing | Opcode::AutoSetup)
    }
}

impl fmt::Display for Opcode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.name(), self.value())
    }
}

/// The whole PDI-Cmd byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Command {
    pub opcode: Opcode,
    /// Bit 6: brake with a ramp to speed 0, keep the control active (travel commands only).
    pub halt: bool,
    /// Bit 7: flipped to execute the same command again.
    pub toggle: bool,
}

impl Command {
    pub const HALT_BIT: u8 = 0x40;
    pub const TOGGLE_BIT: u8 = 0x80;
    pub const OPCODE_MASK: u8 = 0x3F;

    pub fn new(opcode: Opcode) -> Self {
        Self {
            opcode,
            halt: false,
            toggle: false,
        }
    }

    pub fn to_byte(self) -> u8 {
        self.opcode.value()
            | if self.halt { Self::HALT_BIT } else { 0 }
            | if self.toggle { Self::TOGGLE_BIT } else { 0 }
    }

    /// The byte as the SIGNED08 object 2291h:04h holds it.
    pub fn to_i8(self) -> i8 {
        self.to_byte() as i8
    }

    /// Decode a PDI-Cmd byte. An opcode outside the 13 of the spec is an error, never a
    /// silent NOP.
    pub fn from_byte(byte: u8) -> Result<Self, Error> {
        Ok(Self {
            opcode: Opcode::from_value(byte & Self::OPCODE_MASK)?,
            halt: byte & Self::HALT_BIT != 0,
            toggle: byte & Self::TOGGLE_BIT != 0,
        })
    }

    pub fn from_i8(value: i8) -> Result<Self, Error> {
        Self::from_byte(value as u8)
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.opcode.name())?;
        if self.halt {
            f.write_str(" +halt")?;
        }
        if self.toggle {
            f.write_str(" +toggle")?;
        }
        write!(f, " [{}]", self.to_byte())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_opcode_has_the_value_of_the_spec_table() {
        let values: Vec<u8> = Opcode::ALL.iter().map(|op| op.value()).collect();
        assert_eq!(values, [0, 1, 2, 3, 14, 15, 16, 17, 18, 20, 21, 23, 25]);
        for op in Opcode::ALL {
            assert_eq!(Opcode::from_value(op.value()), Ok(op));
        }
    }

    #[test]
    fn spec_examples_encode_to_their_bytes() {
        let halt = Command {
            opcode: Opcode::MoveAbsolute,
            halt: true,
            toggle: false,
        };
        assert_eq!(halt.to_byte(), 84);
        let resume_new = Command {
            opcode: Opcode::MoveAbsolute,
            halt: false,
            toggle: true,
        };
        assert_eq!(resume_new.to_byte(), 148);
        let again = Command {
            opcode: Opcode::MoveRelative,
            halt: false,
            toggle: true,
        };
        assert_eq!(again.to_byte(), 149);
        assert_eq!(again.to_i8(), -107);
        assert_eq!(Command::from_i8(-107), Ok(again));
    }

    #[test]
    fn unknown_opcodes_are_errors() {
        for value in 0u8..=63 {
            let known = Opcode::ALL.iter().any(|op| op.value() == value);
            let decoded = Command::from_byte(value);
            assert_eq!(decoded.is_ok(), known, "opcode {value}");
            if !known {
                assert_eq!(decoded, Err(Error::UnknownOpcode(value)));
            }
        }
    }

    #[test]
    fn every_byte_round_trips_or_errors() {
        for byte in 0u8..=255 {
            if let Ok(cmd) = Command::from_byte(byte) {
                assert_eq!(cmd.to_byte(), byte);
            }
        }
    }
}
