//! A value edited in place, as data: the box's text checked as it is typed (the type's
//! range and the object's limits), and the write it asks to confirm.
//!
//! A model: no egui here.

use super::{Browser, Cell, Confirm, Edit};
use crate::od::{Entry, Value};

/// Check what the user typed for `entry`: its type, its range and its limits.
pub fn parse_edit(entry: &Entry, text: &str) -> Result<Value, String> {
    let value = Value::parse(entry.dtype, text).map_err(|e| e.to_string())?;
    entry.check(&value).map_err(|e| e.to_string())?;
    Ok(value)
}

/// Start editing `entry`'s value, the box taking the keyboard.
pub(super) fn start_edit(b: &mut Browser, entry: &Entry) {
    let text = edit_text(b.values.get(&entry.address), entry);
    b.selected = Some(entry.address);
    b.edit = Some(Edit {
        address: entry.address,
        text,
        error: None,
        focus: true,
    });
}

/// What was typed: checked at once, so the reason shows before Enter.
pub(super) fn typed(b: &mut Browser, entry: &Entry, text: String) {
    if let Some(edit) = b.edit.as_mut().filter(|e| e.address == entry.address) {
        edit.error = if text.trim().is_empty() {
            None
        } else {
            parse_edit(entry, &text).err()
        };
        edit.text = text;
    }
}

/// What the edit box starts with: the value as last read (bytes in hex, a flag as 0 or
/// 1), else the default.
fn edit_text(cell: Option<&Cell>, entry: &Entry) -> String {
    match cell.map(|c| &c.result) {
        Some(Ok(Value::Bytes(bytes))) => bytes
            .iter()
            .map(|x| format!("{x:02X}"))
            .collect::<Vec<_>>()
            .join(" "),
        Some(Ok(Value::Text(t))) => t.clone(),
        Some(Ok(Value::Bool(v))) => u8::from(*v).to_string(),
        Some(Ok(v)) => v.to_string(),
        _ => entry
            .default
            .as_ref()
            .map(Value::to_string)
            .unwrap_or_default(),
    }
}

/// The value typed, checked: the confirmation asked for, or why it is refused.
pub(super) fn submit_edit(b: &mut Browser, entry: &Entry) {
    let address = entry.address;
    let before = b
        .values
        .get(&address)
        .and_then(|c| c.result.as_ref().ok().cloned());
    let Some(edit) = b.edit.as_mut().filter(|e| e.address == address) else {
        return;
    };
    match parse_edit(entry, &edit.text) {
        Err(reason) => {
            edit.error = Some(reason);
            // The box keeps the keyboard, to correct the value.
            edit.focus = true;
        }
        Ok(value) => {
            b.confirm = Some(Confirm {
                address,
                name: entry.full_name(),
                dtype: entry.dtype,
                value,
                before,
            });
        }
    }
}
