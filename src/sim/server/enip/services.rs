//! The objects behind the Message Router: the Nanotec OD (64h) and the Identity (01h).

use super::{MAX_REPLY_DATA, abort_reply, error};
use crate::cia::AbortCode;
use crate::od::Value;
use crate::proto::enip::cip::{GeneralStatus, Reply, service};
use crate::proto::enip::identity::Identity;
use crate::proto::enip::nanotec::{self, Typed};
use crate::sim::Drive;

pub(super) fn od_service(
    service: u8,
    instance: Option<u16>,
    data: &[u8],
    drive: &mut Drive,
) -> Reply {
    if instance != Some(1) {
        return error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN);
    }
    match service {
        service::GET_OD | service::GET_OD_ROCKWELL => get_od(service, data, drive),
        service::SET_OD => set_od(service, data, drive),
        _ => error(service, GeneralStatus::SERVICE_NOT_SUPPORTED),
    }
}

/// GetOD (the bytes) and the Rockwell variant (the bytes with their type).
fn get_od(service: u8, data: &[u8], drive: &Drive) -> Reply {
    if data.len() < 3 {
        return error(service, GeneralStatus::NOT_ENOUGH_DATA);
    }
    if data.len() > 3 {
        return error(service, GeneralStatus::TOO_MUCH_DATA);
    }
    let Ok((address, _)) = nanotec::decode_request_data(data) else {
        return error(service, GeneralStatus::NOT_ENOUGH_DATA);
    };
    let read = drive.read(address).and_then(|value| {
        let dtype = drive
            .entry(address)
            .map(|e| e.dtype)
            .ok_or(AbortCode::NO_OBJECT)?;
        let bytes = value
            .to_le_bytes(dtype)
            .map_err(|_| AbortCode::GENERAL_ERROR)?;
        Ok((dtype, bytes))
    });
    match read {
        Err(abort) => abort_reply(service, abort),
        Ok((_, bytes)) if bytes.len() > MAX_REPLY_DATA => {
            error(service, GeneralStatus::REPLY_TOO_LARGE)
        }
        Ok((_, bytes)) if service == service::GET_OD => Reply::success(service, bytes),
        Ok((dtype, bytes)) => Reply::success(
            service,
            Typed {
                dtype_code: dtype.code(),
                data: bytes,
            }
            .encode(),
        ),
    }
}

/// SetOD: a writable object, as many bytes as its type holds.
fn set_od(service: u8, data: &[u8], drive: &mut Drive) -> Reply {
    if data.len() < 4 {
        return error(service, GeneralStatus::NOT_ENOUGH_DATA);
    }
    let Ok((address, value)) = nanotec::decode_request_data(data) else {
        return error(service, GeneralStatus::NOT_ENOUGH_DATA);
    };
    if value.len() > 4 {
        return error(service, GeneralStatus::TOO_MUCH_DATA);
    }
    let Some(entry) = drive.entry(address) else {
        return abort_reply(
            service,
            drive.read(address).err().unwrap_or(AbortCode::NO_OBJECT),
        );
    };
    if !entry.access.writable() {
        return abort_reply(service, AbortCode::READ_ONLY);
    }
    let dtype = entry.dtype;
    match dtype.size() {
        Some(size) if value.len() < size => {
            return error(service, GeneralStatus::NOT_ENOUGH_DATA);
        }
        Some(size) if value.len() > size => {
            return error(service, GeneralStatus::TOO_MUCH_DATA);
        }
        _ => {}
    }
    let Ok(value) = Value::from_le_bytes(dtype, value) else {
        return abort_reply(service, AbortCode::TYPE_LENGTH_MISMATCH);
    };
    match drive.write(address, value) {
        Ok(()) => Reply::success(service, vec![]),
        Err(abort) => abort_reply(service, abort),
    }
}

pub(super) fn identity_service(
    service: u8,
    instance: Option<u16>,
    attribute: Option<u16>,
    identity: &Identity,
) -> Reply {
    if instance != Some(1) {
        return error(service, GeneralStatus::PATH_DESTINATION_UNKNOWN);
    }
    let mut all = Vec::with_capacity(48);
    identity.encode_attributes(&mut all);
    match service {
        service::GET_ATTRIBUTES_ALL => Reply::success(service, all),
        service::GET_ATTRIBUTE_SINGLE => {
            // Offsets of attributes 1 to 7 in Get_Attributes_All.
            let range = match attribute {
                Some(1) => 0..2,
                Some(2) => 2..4,
                Some(3) => 4..6,
                Some(4) => 6..8,
                Some(5) => 8..10,
                Some(6) => 10..14,
                Some(7) => 14..all.len(),
                _ => return error(service, GeneralStatus::ATTRIBUTE_NOT_SUPPORTED),
            };
            Reply::success(service, all.get(range).unwrap_or_default().to_vec())
        }
        _ => error(service, GeneralStatus::SERVICE_NOT_SUPPORTED),
    }
}
