//! Store, restore factory values and reboot (protocol notes §4.2.1): "save" to 1010h:01
//! keeps the values written so far for the next power-on; "load" to 1011h:01 brings the
//! factory values back at the next restart; "boot" to 2800h:01 restarts the firmware —
//! the drive is off every bus for [`BOOT_TIME`], then starts again switched off, with its
//! position counter at 0 and the values stored (or the factory's).

use std::collections::BTreeMap;
use std::time::Duration;

use super::Drive;
use crate::cia::AbortCode;
use crate::od::{Access, Address, Value};
use crate::pdi::PDI_INPUT;

/// "save" in ASCII, read as a little-endian u32.
pub const SAVE: i128 = 0x6576_6173;
/// "load".
pub const LOAD: i128 = 0x6461_6F6C;
/// "boot".
pub const BOOT: i128 = 0x746F_6F62;

/// How long the simulated drive is gone while it restarts.
pub const BOOT_TIME: Duration = Duration::from_millis(1500);

/// What survives a restart.
#[derive(Clone, Debug, Default)]
pub(super) struct Storage {
    /// The values stored by the last "save" (none: the factory's).
    stored: Option<BTreeMap<Address, Value>>,
    /// Whether the motor was measured (auto setup) when the values were stored.
    stored_autosetup: bool,
    /// "load" was written: the next restart brings the factory values back.
    restore_pending: bool,
    /// The restart begins then (its own time) and lasts until `booting_until`.
    boot_from: Option<Duration>,
    booting_until: Option<Duration>,
}

/// Objects a store leaves out: what a master writes cyclically or to command the drive.
fn volatile(address: Address) -> bool {
    matches!(address.index, PDI_INPUT | 0x6040 | 0x1010 | 0x1011 | 0x2800)
}

impl Drive {
    /// A write to 1010h, 1011h or 2800h (a subindex above 0): the signature checked, and
    /// what it asks for done.
    pub(super) fn storage_command(
        &mut self,
        address: Address,
        value: &Value,
    ) -> Result<(), AbortCode> {
        let given = value.as_i128();
        match address.index {
            0x1010 if given == Some(SAVE) => {
                let stored = self
                    .od
                    .addresses()
                    .filter(|a| !volatile(*a))
                    .filter(|a| self.od.entry(*a).is_some_and(|e| e.access == Access::Rw))
                    .filter_map(|a| self.od.get(a).map(|v| (a, v.clone())))
                    .collect();
                self.storage.stored = Some(stored);
                self.storage.stored_autosetup = self.autosetup_done;
                self.storage.restore_pending = false;
                Ok(())
            }
            0x1011 if given == Some(LOAD) => {
                self.storage.restore_pending = true;
                Ok(())
            }
            0x2800 if given == Some(BOOT) => {
                // After the delay of 2800h:02 (ms), if one is set.
                let delay = Duration::from_millis(self.od.int(0x2800, 2).max(0) as u64);
                self.storage.boot_from = Some(self.time + delay);
                self.storage.booting_until = Some(self.time + delay + BOOT_TIME);
                Ok(())
            }
            0x1010 | 0x1011 => Err(AbortCode::CANNOT_STORE),
            _ => Err(AbortCode::VALUE_RANGE),
        }
    }

    /// Whether the drive is restarting: it answers nothing on any bus.
    pub fn rebooting(&self) -> bool {
        self.storage.boot_from.is_some_and(|from| self.time >= from)
    }

    /// The restart, once its time has come: a drive as at power-on, with the stored
    /// values, the same machine and load, the load where it stands.
    pub(super) fn finish_reboot(&mut self) {
        let Some(until) = self.storage.booting_until else {
            return;
        };
        if self.rebooting() {
            // The power stage goes off with the firmware: the motor coasts.
            self.state = crate::cia::PowerState::SwitchOnDisabled;
        }
        if self.time < until {
            return;
        }
        let mut storage = std::mem::take(&mut self.storage);
        storage.booting_until = None;
        storage.boot_from = None;
        if storage.restore_pending {
            storage.stored = None;
            storage.stored_autosetup = false;
            storage.restore_pending = false;
        }
        let mut fresh = Drive::from_dictionary(self.factory.clone(), self.world);
        if let Some(stored) = &storage.stored {
            for (address, value) in stored {
                fresh.od.set(*address, value.clone());
            }
        }
        fresh.autosetup_done = storage.stored_autosetup;
        fresh.time = self.time;
        // The load does not move for a restart; the position counter starts at 0.
        fresh.x = self.x;
        fresh.offset = self.x;
        fresh.demand.position = self.x;
        fresh.storage = storage;
        fresh.reboots = self.reboots + 1;
        *self = fresh;
        self.publish();
    }

    /// How often the drive restarted since it was made.
    pub fn reboots(&self) -> u32 {
        self.reboots
    }
}
