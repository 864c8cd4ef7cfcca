use super::DataType;

/// Errors of the object-dictionary layer: addresses, values, catalogs.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Error {
    #[error("'{0}' is not an object address: write INDEX:SUB in hex, e.g. 1018:01 or 6041")]
    BadAddress(String),

    #[error("'{text}' is not a valid {dtype} value")]
    NotANumber { text: String, dtype: DataType },

    #[error(
        "{value} is out of range for {dtype}: {}",
        crate::number::range_text(min, max)
    )]
    OutOfRange {
        value: String,
        dtype: DataType,
        min: String,
        max: String,
    },

    #[error("{value} is above the object's maximum {max}")]
    TooHigh { value: String, max: String },

    #[error("{value} is below the object's minimum {min}")]
    TooLow { value: String, min: String },

    #[error("{0} is not an integer type")]
    NotAnInteger(DataType),

    #[error("a {dtype} value is {expected} bytes, the device sent {got}")]
    Length {
        dtype: DataType,
        expected: usize,
        got: usize,
    },

    #[error("{value} is not a {dtype} value")]
    TypeMismatch { dtype: DataType, value: String },

    #[error("{0} values do not fit the 32-bit PDI; use an SDO, FC 43 or CIP link for them")]
    NotPdiSized(DataType),

    #[error("catalog: {0}")]
    Catalog(String),
}
