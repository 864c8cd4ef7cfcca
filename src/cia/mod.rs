//! CiA 301 / CiA 402 vocabulary shared by every layer: SDO abort codes, drive error codes
//! and the power state machine. Pure data and text, std only, so that `pdi` (which may
//! depend on nothing else of the project) can name an abort code too.

pub mod abort;
pub mod error_code;
pub mod power_state;

pub use abort::AbortCode;
pub use error_code::{ErrorCode, HistoryEntry, error_register_text};
pub use power_state::PowerState;
