//! Watched objects: what the watch panel pins, per drive in a project and in the window's
//! saved layout alike (the window's `ui::watch` uses these types).

use serde::{Deserialize, Serialize};

use crate::od::Address;

/// At most this many objects pinned per drive (one `ReadMany` of them must fit a refresh
/// period).
pub const MAX_PINS: usize = 32;

/// How a pinned value is shown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Format {
    /// Decimal with the unit.
    #[default]
    Decimal,
    /// Hex, as wide as the type.
    Hex,
    /// Hex, and every bit the catalog names, set or clear.
    Bits,
}

impl Format {
    pub const ALL: [Format; 3] = [Format::Decimal, Format::Hex, Format::Bits];

    pub fn name(self) -> &'static str {
        match self {
            Format::Decimal => "dec",
            Format::Hex => "hex",
            Format::Bits => "bits",
        }
    }
}

/// One pinned object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pin {
    pub address: Address,
    pub format: Format,
}
