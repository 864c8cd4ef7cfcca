//! The simulated drive's digital inputs and outputs, as the Nanotec manuals describe
//! 3240h (PD4-C manual 1.4.1, PD4-E-M manual 1.0.1; protocol notes §4.2.3):
//!
//! 1. the **electrical level** of each input, bit n−1 for input n, shown unmodified in
//!    3240h:05 (Raw Value). The simulated machine's wiring: a normally closed negative
//!    limit switch on input 1 and a positive one on input 2 (high while not pressed, so a
//!    broken wire reads low), a normally open home switch on input 3, and a test loop
//!    from outputs 1 and 2 to inputs 5 and 6 (so forcing an output shows on an input);
//! 2. the **logical level**: inverted where 3240h:02 has the input's bit, then replaced by
//!    3240h:04 where 3240h:03 (Force Enable) has it. 60FDh bits 16 and up show it;
//! 3. the **special functions**: where 3240h:01 has bit n−1, input n is 60FDh bit n−1
//!    (input 1 the negative limit switch, 2 the positive one, 3 the home switch, 4 the
//!    interlock), and only then does the drive act on it (a limit switch stops travel into
//!    it). 3240h:01 has no effect on bits 16 and up.
//!
//! The simulated drive leaves its factory with the special functions of inputs 1–3 on and
//! inputs 1–2 inverted (3240h:01 = 7, :02 = 3): its limit switches stop it out of the box,
//! and a broken wire to one (the `wire-break` injection, on input 1) reads as a pressed
//! switch, as normally closed wiring intends. Homing finds the switches where the machine
//! has them (the world's positions), whatever 3240h says.
//!
//! The outputs: 60FEh:01 drives output n (bit 15+n) where the mask 60FEh:02 has its bit;
//! the simulated drive has no function of its own on an output, so an unmasked one is off.

use super::Drive;
use crate::injection::Injection;
use crate::sim::world::Sensors;

/// Inputs modelled (1–8).
pub const INPUTS: u8 = 8;
/// The inputs the simulated machine wires its switches to.
pub const NEGATIVE_LIMIT_INPUT: u8 = 1;
pub const POSITIVE_LIMIT_INPUT: u8 = 2;
pub const HOME_INPUT: u8 = 3;
/// Outputs 1 and 2 are looped back to inputs 5 and 6.
pub const LOOPED_OUTPUTS: [(u8, u8); 2] = [(1, 5), (2, 6)];
/// 3240h:01 and :02 as the simulated drive leaves the factory.
pub const FACTORY_SPECIAL: u32 = 0b0111;
pub const FACTORY_INVERTED: u32 = 0b0011;

/// The simulated drive's factory values that differ from the catalog's (the manuals'
/// presets): its switches' special functions and inversion.
pub const FACTORY_SETTINGS: [(u16, u8, u32); 2] =
    [(0x3240, 1, FACTORY_SPECIAL), (0x3240, 2, FACTORY_INVERTED)];

/// Input n's bit in 3240h's words (bit n−1).
fn input_bit(n: u8) -> u32 {
    1 << (n - 1)
}

/// Output n's bit in 60FEh (bit 15+n).
pub fn output_bit(n: u8) -> u32 {
    1 << (15 + n)
}

impl Drive {
    /// The outputs as they are switched: 60FEh:01 where 60FEh:02 enables it.
    pub fn physical_outputs(&self) -> u32 {
        let value = self.od.int(0x60FE, 1) as u32;
        let mask = self.od.int(0x60FE, 2) as u32;
        value & mask & 0xFFFF_0000
    }

    /// The electrical level of each input, bit n−1 for input n (3240h:05).
    pub fn input_levels(&self) -> u32 {
        let at = self.world.sensors(self.x);
        let mut levels = 0;
        let mut set = |n: u8, high: bool| {
            if high {
                levels |= input_bit(n);
            }
        };
        let broken = self.injected.contains(&Injection::WireBreak);
        // Normally closed: high while not pressed; a broken wire is low.
        set(NEGATIVE_LIMIT_INPUT, !at.negative_limit && !broken);
        set(POSITIVE_LIMIT_INPUT, !at.positive_limit);
        set(HOME_INPUT, at.home);
        let outputs = self.physical_outputs();
        for (output, input) in LOOPED_OUTPUTS {
            set(input, outputs & output_bit(output) != 0);
        }
        levels
    }

    /// The logical inputs, bit n−1 for input n: inverted by 3240h:02, then forced by
    /// 3240h:03/:04.
    pub fn logical_inputs(&self) -> u32 {
        let word = |sub: u8| self.od.int(0x3240, sub) as u32;
        let (inverted, force, forced) = (word(2), word(3), word(4));
        let logical = self.input_levels() ^ inverted;
        (logical & !force) | (forced & force)
    }

    /// The switches as the firmware acts on them: an input's special function counts
    /// only where 3240h:01 enables it.
    pub fn switches(&self) -> Sensors {
        let special = self.od.int(0x3240, 1) as u32 & self.logical_inputs();
        let on = |n: u8| special & input_bit(n) != 0;
        Sensors {
            negative_limit: on(NEGATIVE_LIMIT_INPUT),
            positive_limit: on(POSITIVE_LIMIT_INPUT),
            home: on(HOME_INPUT),
        }
    }

    /// 60FDh: the special functions in bits 0–3, the logical inputs from bit 16.
    pub fn digital_inputs(&self) -> u32 {
        let logical = self.logical_inputs() & ((1 << INPUTS) - 1);
        let special = self.od.int(0x3240, 1) as u32 & logical & 0b1111;
        special | (logical << 16)
    }
}
