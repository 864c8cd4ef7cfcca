//! The object dictionary: addresses, CANopen data types, typed values and the catalog of
//! known objects (built in from `assets/od/`, or imported from an EDS file, see `eds`).

pub mod backup;
mod catalog;
pub mod eds;
mod error;
pub mod gains;
pub mod io;
pub mod nanoj;
mod role;
mod types;
mod value;

pub use catalog::{BUILTIN_JSON, Catalog, Entry, Group, builtin};
pub use error::Error;
pub use role::Role;
pub use types::{Access, Address, DataType};
pub use value::Value;
