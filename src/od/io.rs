//! The digital inputs and outputs in words, one place for the window's I/O tab and
//! `drivedeck io` (protocol notes §4.2.3, from the PD4-C 1.4.1 and PD4-E-M 1.0.1 manuals):
//!
//! * 60FDh: bits 0–3 the special functions (negative limit switch, positive limit switch,
//!   home switch, interlock), from bit 16 the physical inputs 1, 2, … as the drive reads
//!   them (after inversion and forcing);
//! * 3240h: bit n−1 of each word is input n: :01 its special function on, :02 inverted,
//!   :03 forced (to :04's bit), :05 the raw level at the terminal;
//! * 60FEh: :01 the outputs (output n at bit 15+n), :02 the mask of the outputs the
//!   master drives.

/// Physical inputs and outputs shown (bits 16 on).
pub const PHYSICAL: u8 = 8;

/// The special functions' names, 60FDh bits 0–3 (served by inputs 1–4 where 3240h:01
/// enables them).
pub const SPECIAL: [&str; 4] = [
    "negative limit switch",
    "positive limit switch",
    "home switch",
    "interlock",
];

/// Output n's bit (1–8) in 60FEh:01 and :02.
pub fn output_bit(n: u8) -> u32 {
    1u32 << (15 + n)
}

/// The words the inputs are read from; `None` where a word was not read (an older
/// firmware without 3240h:05, a refusal).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InputWords {
    /// 60FDh.
    pub inputs: Option<u32>,
    /// 3240h:01 Special Function Enable.
    pub special: Option<u32>,
    /// 3240h:02 Function Inverted.
    pub inverted: Option<u32>,
    /// 3240h:03 Force Enable.
    pub forced: Option<u32>,
    /// 3240h:05 Raw Value.
    pub raw: Option<u32>,
}

/// One line of the inputs: a 60FDh bit by name, and for a physical input how 3240h
/// treats it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputLine {
    /// The bit in 60FDh.
    pub bit: u8,
    pub name: String,
    pub on: Option<bool>,
    /// The special function it serves (inputs 1–4, where 3240h:01 enables it).
    pub function: Option<&'static str>,
    pub inverted: Option<bool>,
    pub forced: Option<bool>,
    /// The level at the terminal (3240h:05), before inversion and forcing.
    pub raw: Option<bool>,
}

impl InputLine {
    /// What 3240h does with it, in words: "negative limit switch", "inverted", "forced",
    /// "terminal low" (where the terminal's level differs from what the drive reads).
    pub fn notes(&self) -> Vec<String> {
        let mut notes = vec![];
        if let Some(function) = self.function {
            notes.push(function.to_owned());
        }
        if self.inverted == Some(true) {
            notes.push("inverted".to_owned());
        }
        if self.forced == Some(true) {
            notes.push("forced".to_owned());
        }
        if let (Some(raw), Some(on)) = (self.raw, self.on)
            && raw != on
        {
            notes.push(format!("terminal {}", if raw { "high" } else { "low" }));
        }
        notes
    }

    /// "input 1 (negative limit switch, inverted, terminal high)".
    pub fn label(&self) -> String {
        let notes = self.notes();
        if notes.is_empty() {
            self.name.clone()
        } else {
            format!("{} ({})", self.name, notes.join(", "))
        }
    }
}

/// Every line: the four special functions, then the physical inputs 1–[`PHYSICAL`].
pub fn input_lines(words: &InputWords) -> Vec<InputLine> {
    let bit_of = |word: Option<u32>, bit: u8| word.map(|w| w & (1 << bit) != 0);
    let special = SPECIAL.iter().enumerate().map(|(bit, name)| InputLine {
        bit: bit as u8,
        name: (*name).to_owned(),
        on: bit_of(words.inputs, bit as u8),
        function: None,
        inverted: None,
        forced: None,
        raw: None,
    });
    let physical = (1..=PHYSICAL).map(|n| {
        let k = n - 1;
        let serves = SPECIAL
            .get(usize::from(k))
            .filter(|_| bit_of(words.special, k) == Some(true));
        InputLine {
            bit: 15 + n,
            name: format!("input {n}"),
            on: bit_of(words.inputs, 15 + n),
            function: serves.copied(),
            inverted: bit_of(words.inverted, k),
            forced: bit_of(words.forced, k),
            raw: bit_of(words.raw, k),
        }
    });
    special.chain(physical).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_simulated_machines_words_in_words() {
        // Between the switches, output 1 looped to input 5, input 7 forced high.
        let words = InputWords {
            inputs: Some(1 << 20 | 1 << 22),
            special: Some(0b111),
            inverted: Some(0b011),
            forced: Some(0b100_0000),
            raw: Some(0b1_0011),
        };
        let lines = input_lines(&words);
        assert_eq!(lines.len(), 12);
        assert_eq!(lines[0].label(), "negative limit switch");
        assert_eq!(lines[0].on, Some(false));
        assert_eq!(
            lines[4].label(),
            "input 1 (negative limit switch, inverted, terminal high)"
        );
        assert_eq!(lines[6].label(), "input 3 (home switch)");
        assert_eq!(lines[7].label(), "input 4");
        assert_eq!(lines[8].label(), "input 5");
        assert_eq!(lines[8].on, Some(true));
        assert_eq!(lines[10].label(), "input 7 (forced, terminal low)");
        // Nothing read: names only.
        let unknown = input_lines(&InputWords::default());
        assert_eq!(unknown[4].label(), "input 1");
        assert_eq!(unknown[4].on, None);
    }
}
