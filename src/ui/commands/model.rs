//! The command panel's rules: a command's inputs, validated into the request to send (or
//! why not), and the warning shown under a valid command that will not do what one might
//! expect.
//!
//! A model: no egui here.

use crate::od::{self, Address, DataType, Value};
use crate::pdi::{Action, Opcode};
use crate::ui::drive::Drive;
use crate::worker::{ObjectPath, Request};

/// A command's inputs, validated: the request to send, or why not.
pub fn validate(drive: &Drive, opcode: Opcode) -> Result<Request, String> {
    let specs = opcode.fields();
    let texts = drive
        .settings
        .inputs
        .get(opcode.name())
        .cloned()
        .unwrap_or_default();
    let text = |i: usize| texts.get(i).map(String::as_str).unwrap_or("");
    match opcode {
        Opcode::OdRead | Opcode::OdWrite => {
            let index = specs[0].parse(text(0)).map_err(|e| e.to_string())?;
            let sub = specs[1].parse(text(1)).map_err(|e| e.to_string())?;
            let address = Address::new(index as u16, sub as u8);
            let entry = od::builtin().get(address);
            if opcode == Opcode::OdRead {
                return Ok(Request::ReadObject {
                    address,
                    dtype: entry.map(|e| e.dtype),
                    path: ObjectPath::Pdi,
                });
            }
            let (dtype, value) = match entry {
                Some(entry) => {
                    if !entry.access.writable() {
                        return Err(format!("{address} {} is read-only", entry.full_name()));
                    }
                    let value =
                        Value::parse(entry.dtype, text(2)).map_err(|e| format!("Value: {e}"))?;
                    entry.check(&value).map_err(|e| format!("Value: {e}"))?;
                    if !entry.dtype.fits_pdi() {
                        return Err(format!("{} values do not fit the 32-bit PDI", entry.dtype));
                    }
                    (entry.dtype, value)
                }
                None => {
                    let raw = specs[2].parse(text(2)).map_err(|e| e.to_string())?;
                    let value = if raw < 0 {
                        Value::Int(raw)
                    } else {
                        Value::Uint(raw as u64)
                    };
                    let dtype = if raw < 0 {
                        DataType::Integer32
                    } else {
                        DataType::Unsigned32
                    };
                    (dtype, value)
                }
            };
            Ok(Request::WriteObject {
                address,
                dtype,
                value,
                path: ObjectPath::Pdi,
            })
        }
        _ => {
            let mut values = Vec::with_capacity(specs.len());
            for (i, spec) in specs.iter().enumerate() {
                values.push(spec.parse(text(i)).map_err(|e| e.to_string())?);
            }
            Action::from_inputs(opcode, &values)
                .map(Request::Command)
                .map_err(|e| e.to_string())
        }
    }
}

/// A warning shown under a valid command that will not do what one might expect.
pub fn caution(drive: &Drive, request: &Request) -> Option<String> {
    match request {
        Request::Command(Action::MoveAbsolute { speed: 0, .. })
        | Request::Command(Action::MoveRelative { speed: 0, .. }) => {
            Some("Max speed 0: the drive will not move.".into())
        }
        Request::Command(Action::Torque { max_speed: 0, .. }) => {
            Some("Max speed 0: the motor will not turn.".into())
        }
        Request::Command(Action::Torque { .. }) => match drive.motion.torque_slope {
            Some(0) => Some("Torque slope 6087h is 0: the torque will never build up.".into()),
            None => Some("Torque slope 6087h unknown: read it before sending.".into()),
            Some(_) => None,
        },
        Request::Command(Action::Homing { method })
            if drive
                .link_info()
                .and_then(|i| i.homing_methods.as_ref())
                .is_some_and(|methods| !methods.contains(method)) =>
        {
            Some(format!("Method {method} is not one this device supports."))
        }
        _ => None,
    }
}
