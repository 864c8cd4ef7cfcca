//! Object access as a master sees it, and the PDI process images.

use super::Drive;
use crate::cia::AbortCode;
use crate::od::{Address, DataType, Value};
use crate::pdi::{PDI_INPUT, RX_OBJECTS, RxImage, SetValues, TxImage};

impl Drive {
    /// Read an object as a master would (SDO, FC 43, CIP 32h…).
    pub fn read(&self, address: Address) -> Result<Value, AbortCode> {
        self.od.read(address)
    }

    /// How many objects were set from outside the drive's own cycle: unchanged, no mapping
    /// changed (see `Dictionary::changes`).
    pub fn od_changes(&self) -> u64 {
        self.od.changes()
    }

    /// The catalog entry behind an address, if the drive has it.
    pub fn entry(&self, address: Address) -> Option<&crate::od::Entry> {
        self.od.entry(address)
    }

    /// Read an object with the type its bytes are coded in: its catalog entry's, or
    /// Integer32 where the drive knows no entry.
    pub fn read_typed(&self, address: Address) -> Result<(Value, DataType), AbortCode> {
        let value = self.read(address)?;
        let dtype = self.entry(address).map_or(DataType::Integer32, |e| e.dtype);
        Ok((value, dtype))
    }

    /// Every address the drive holds.
    pub fn addresses(&self) -> impl Iterator<Item = Address> + '_ {
        self.od.addresses()
    }

    /// Set an object as the drive itself would (no access check, no side effects): for the
    /// servers that configure communication objects, e.g. PDO COB-IDs from the node id.
    pub fn set_raw(&mut self, address: Address, value: Value) {
        self.od.set(address, value);
    }

    /// Write an object as a master would. Writes to 2291h:04h run the PDI command.
    pub fn write(&mut self, address: Address, value: Value) -> Result<(), AbortCode> {
        self.od.check_write(address, &value)?;
        match (address.index, address.sub) {
            (PDI_INPUT, 4) => {
                let byte = value.as_i128().unwrap_or(0) as u8;
                self.od.set(address, value);
                self.on_command_byte(byte);
            }
            (0x2300, 0) => {
                let control = value.as_i128().unwrap_or(0) as i64;
                self.od.set(address, value);
                self.nanoj_control(control);
            }
            (0x6040, 0) => {
                let word = value.as_i128().unwrap_or(0) as u16;
                self.od.set(address, value);
                self.on_controlword(word);
            }
            (0x1003, 0) => {
                if value.as_i128() != Some(0) {
                    return Err(AbortCode::VALUE_RANGE);
                }
                for sub in 0..=8 {
                    self.od.set_int(0x1003, sub, 0);
                }
            }
            (0x1010 | 0x1011, 1..) | (0x2800, 1) => {
                self.storage_command(address, &value)?;
            }
            _ => self.od.set(address, value),
        }
        self.publish();
        Ok(())
    }

    /// The RX process image as a cyclic master writes it: set values first, then the
    /// command byte (so a new command always sees its own set values).
    pub fn write_rx(&mut self, rx: &RxImage) {
        // The image the drive holds already (a cyclic master sends it every cycle): no value
        // to set, no command, and nothing to publish that is not published (every change of
        // the drive's state publishes as it happens). Publishing it again was an eighth of
        // what the Modbus TCP server spent on an FC 23.
        if *rx == self.rx_image() {
            return;
        }
        // RX_OBJECTS ends with the command byte.
        for (object, value) in rx.object_values() {
            self.od.set_int(object.index, object.sub, value);
        }
        self.on_command_byte(rx.cmd);
        self.publish();
    }

    /// The RX image the drive holds now (2291h), read back.
    pub fn rx_image(&self) -> RxImage {
        RxImage {
            values: self.set_values(),
            cmd: self.last_cmd,
        }
    }

    /// The TX process image: PDI-Status, 603Fh, PDI-ReturnValue.
    pub fn tx_image(&self) -> TxImage {
        TxImage {
            status: self.pdi_status(),
            error_code: self.reported_error_code().0,
            return_value: self.return_value(),
        }
    }

    pub(super) fn set_values(&self) -> SetValues {
        // The command byte is not part of the set values: the image's is left at 0.
        RxImage::from_object_values(|o| {
            if o == RX_OBJECTS[3] {
                0
            } else {
                self.od.int(o.index, o.sub)
            }
        })
        .values
    }
}
