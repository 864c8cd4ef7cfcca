//! What the adapter's assemblies, identity and ListServices reply hold, read from the drive.

use std::net::SocketAddrV4;

use super::{DEVICE_TYPE, SERVICE_FLAGS, STATE_OPERATIONAL, STATUS_OWNED, int_of};
use crate::od::{Address, Value};
use crate::proto::enip::assembly::{self, CommonIn, CommonOut};
use crate::proto::enip::cpf::{self, Item, SockAddr};
use crate::proto::enip::identity::{Identity, NANOTEC_VENDOR};
use crate::proto::enip::wire::Put;
use crate::sim::Drive;

/// Assembly 100 from the drive.
pub fn common_in(drive: &Drive) -> CommonIn {
    let mut nanoj_outputs = [0i32; assembly::NANOJ_OUTPUTS];
    for (i, v) in nanoj_outputs.iter_mut().enumerate() {
        *v = int_of(drive, 0x2500, i as u8 + 1) as i32;
    }
    CommonIn {
        tx: drive.tx_image(),
        position: int_of(drive, 0x6064, 0) as i32,
        velocity: int_of(drive, 0x606C, 0) as i32,
        digital_inputs: int_of(drive, 0x60FD, 0) as u32,
        torque: int_of(drive, 0x6077, 0) as i16,
        analog_input: int_of(drive, 0x3220, 1) as i16,
        following_error: int_of(drive, 0x60F4, 0) as i32,
        nanoj_outputs,
    }
}

/// Assembly 101 as the drive holds it now.
pub fn common_out(drive: &Drive) -> CommonOut {
    let mut nanoj_inputs = [0i32; assembly::NANOJ_INPUTS];
    for (i, v) in nanoj_inputs.iter_mut().enumerate() {
        *v = int_of(drive, 0x2400, i as u8 + 1) as i32;
    }
    CommonOut {
        rx: drive.rx_image(),
        digital_outputs: int_of(drive, 0x60FE, 1) as u32,
        nanoj_inputs,
    }
}

/// The drive's identity, announced at `socket`.
pub fn identity_of(drive: &Drive, socket: SocketAddrV4, owned: bool) -> Identity {
    let revision = int_of(drive, 0x1018, 3) as u32;
    let mut name = match drive.read(Address::new(0x1008, 0)) {
        Ok(Value::Text(text)) => text,
        _ => String::new(),
    };
    let mut cut = name.len().min(32);
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    name.truncate(cut);
    Identity {
        encap_version: 1,
        socket: SockAddr::new(socket),
        vendor: NANOTEC_VENDOR,
        device_type: DEVICE_TYPE,
        product_code: int_of(drive, 0x1018, 2) as u16,
        revision: (((revision >> 16) as u8).clamp(1, 127), revision as u8),
        status: if owned { STATUS_OWNED } else { 0 },
        serial: int_of(drive, 0x1018, 4) as u32,
        product_name: name,
        state: STATE_OPERATIONAL,
    }
}

pub(super) fn services_item() -> Item {
    let mut data = Vec::with_capacity(20);
    data.put_u16(1);
    data.put_u16(SERVICE_FLAGS);
    data.extend_from_slice(b"Communications\0\0");
    Item::Other {
        kind: cpf::LIST_SERVICES,
        data,
    }
}

pub(super) fn cpf_data(items: &[Item]) -> Vec<u8> {
    let mut out = Vec::new();
    cpf::encode(items, &mut out);
    out
}
