//! The Plug & Drive interface (PDI), sans-IO: commands, status bits, set values, the
//! 8-byte process images and the master state machine. Depends on nothing but std (and the
//! shared CiA vocabulary in `cia`).
//!
//! Spec: Nanotec's *Function description Plug & Drive interface* (the PDI spec, see
//! `docs/protocol-notes.md` §0.1), sections 2.1 to 3.

/// A fieldless enum with explicit values, and `ALL`: its variants in declaration order.
/// One list, so that `ALL` cannot miss a variant.
macro_rules! enum_with_all {
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $($variant:ident = $value:literal,)+
        }
    ) => {
        $(#[$meta])*
        pub enum $name {
            $($variant = $value,)+
        }

        impl $name {
            pub const ALL: [$name; [$($value),+].len()] = [$($name::$variant),+];
        }
    };
}

mod action;
mod command;
mod error;
mod image;
mod master;
mod objects;
mod status;

#[cfg(test)]
mod spec_examples;

pub use action::{
    Action, Field, FieldSpec, Radix, SetValues, index_to_set_value2, parse_number,
    set_value2_to_index, set_value3_to_subindex, subindex_to_set_value3,
};
pub use command::{Command, Opcode, ReturnValue};
pub use error::Error;
pub use image::{RxImage, TxImage};
pub use master::{Failure, PdiMaster, Progress, Timing, Travel, Waiting};
pub use objects::{ImageObject, PDI_INPUT, PDI_OUTPUT, RX_OBJECTS, TX_OBJECTS};
pub use status::{Status, StatusBit};
