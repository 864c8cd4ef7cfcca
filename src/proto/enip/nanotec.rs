//! Nanotec's object dictionary services on class 64h instance 1 (EtherNet/IP chapter,
//! "Device profile"; protocol notes §3.3): GetOD (32h), SetOD (33h) and GetOD "Rockwell"
//! (34h). Every value travels little-endian in its native size, 1 to 4 bytes.
//!
//! The vendor's examples are the golden tests below. One of them disagrees with itself
//! (protocol notes §5.2): the 34h reply for 2014h ends `… A8 C8` where the 32h reply for the same
//! object ends `… A8 C0`. The codec decodes the printed bytes exactly as printed; the
//! simulated adapter answers with the object's real value, so a client sees the same IP
//! either way, and the C8 is taken for the typo it most likely is.

use super::cip::{Path, Request, class, service};
use super::wire::{DecodeError, Put, Reader};
use crate::od::Address;

/// `20 64 24 01`: class 64h, instance 1.
pub fn od_path() -> Path {
    Path::object(class::NANOTEC_OD, 1)
}

fn address_bytes(address: Address) -> Vec<u8> {
    let mut out = Vec::with_capacity(7);
    out.put_u16(address.index);
    out.put_u8(address.sub);
    out
}

/// GetOD: read one entry.
pub fn get_od(address: Address) -> Request {
    Request::new(service::GET_OD, &od_path(), address_bytes(address))
}

/// GetOD Rockwell: read one entry with its data type and length in front.
pub fn get_od_rockwell(address: Address) -> Request {
    Request::new(service::GET_OD_ROCKWELL, &od_path(), address_bytes(address))
}

/// SetOD: write one entry; `value` is the object's little-endian bytes, 1 to 4 of them.
pub fn set_od(address: Address, value: &[u8]) -> Result<Request, DecodeError> {
    if !(1..=4).contains(&value.len()) {
        return Err(DecodeError::invalid(
            "SetOD",
            format!(
                "{address} takes {} bytes; SetOD carries 1 to 4 (strings and 64-bit values cannot be written over EtherNet/IP)",
                value.len()
            ),
        ));
    }
    let mut data = address_bytes(address);
    data.extend_from_slice(value);
    Ok(Request::new(service::SET_OD, &od_path(), data))
}

/// The entry a GetOD, GetOD Rockwell or SetOD request names, and the value bytes after it.
pub fn decode_request_data(data: &[u8]) -> Result<(Address, &[u8]), DecodeError> {
    let mut r = Reader::new("object dictionary service data", data);
    let index = r.u16("index")?;
    let sub = r.u8("subindex")?;
    Ok((Address::new(index, sub), r.rest()))
}

/// A GetOD Rockwell reply: the CiA 301 data type code, then the value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Typed {
    pub dtype_code: u16,
    pub data: Vec<u8>,
}

impl Typed {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(4 + self.data.len());
        out.put_u16(self.dtype_code);
        out.put_u16(self.data.len() as u16);
        out.extend_from_slice(&self.data);
        out
    }

    pub fn decode(data: &[u8]) -> Result<Typed, DecodeError> {
        let mut r = Reader::new("GetOD Rockwell reply", data);
        let dtype_code = r.u16("object type")?;
        let length = usize::from(r.u16("data length")?);
        let value = r.take(length, "data")?.to_vec();
        r.end()?;
        Ok(Typed {
            dtype_code,
            data: value,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::cip::{GeneralStatus, Reply};
    use super::*;

    fn bytes(text: &str) -> Vec<u8> {
        text.split_whitespace()
            .map(|b| u8::from_str_radix(b, 16).expect("hex"))
            .collect()
    }

    #[test]
    fn get_od_of_2014h_is_the_vendors_example() {
        // Spec, "Service: Get object dictionary entry": read 2014h:00h (IPv4 address).
        let request = get_od(Address::new(0x2014, 0));
        assert_eq!(request.encode(), bytes("32 02 20 64 24 01 14 20 00"));
        let parsed = Request::decode(&bytes("32 02 20 64 24 01 14 20 00")).unwrap();
        assert_eq!(parsed.path().unwrap(), od_path());
        assert_eq!(
            decode_request_data(&parsed.data).unwrap(),
            (Address::new(0x2014, 0), &[][..])
        );
        let reply = Reply::decode(&bytes("B2 00 00 00 F4 00 A8 C0")).unwrap();
        assert_eq!(
            reply.clone().expect(0x32).unwrap().status,
            GeneralStatus::SUCCESS
        );
        // 192.168.0.244: the first octet in the most significant byte (protocol notes §3.3).
        let ip = u32::from_le_bytes(reply.data.try_into().unwrap());
        assert_eq!(std::net::Ipv4Addr::from(ip).to_string(), "192.168.0.244");
        assert_eq!(
            Reply::success(0x32, vec![0xF4, 0x00, 0xA8, 0xC0]).encode(),
            bytes("B2 00 00 00 F4 00 A8 C0")
        );
    }

    #[test]
    fn set_od_of_2031h_is_the_vendors_example() {
        // "write the value 00000304h in object 2031h:00h (Max Motor Current)".
        let request = set_od(Address::new(0x2031, 0), &0x304u32.to_le_bytes()).unwrap();
        assert_eq!(
            request.encode(),
            bytes("33 02 20 64 24 01 31 20 00 04 03 00 00")
        );
        let (address, value) = decode_request_data(&request.data).unwrap();
        assert_eq!(
            (address, value),
            (Address::new(0x2031, 0), &[4, 3, 0, 0][..])
        );
        assert_eq!(Reply::success(0x33, vec![]).encode(), bytes("B3 00 00 00"));
        assert!(
            Reply::decode(&bytes("B3 00 00 00"))
                .unwrap()
                .expect(0x33)
                .is_ok()
        );
    }

    #[test]
    fn set_od_sizes_the_value_from_one_to_four_bytes() {
        assert_eq!(set_od(Address::new(0x6060, 0), &[1]).unwrap().data.len(), 4);
        assert_eq!(
            set_od(Address::new(0x6040, 0), &[6, 0]).unwrap().data.len(),
            5
        );
        let wide = set_od(Address::new(0x1008, 0), b"too long").unwrap_err();
        assert!(
            wide.to_string().contains("1008h:00h takes 8 bytes"),
            "{wide}"
        );
        assert!(set_od(Address::new(0x6060, 0), &[]).is_err());
    }

    #[test]
    fn get_od_rockwell_as_printed_including_the_c8_typo() {
        let request = get_od_rockwell(Address::new(0x2014, 0));
        assert_eq!(request.encode(), bytes("34 02 20 64 24 01 14 20 00"));
        let reply = Reply::decode(&bytes("B4 00 00 00 07 00 04 00 F4 00 A8 C8")).unwrap();
        let typed = Typed::decode(&reply.expect(0x34).unwrap().data).unwrap();
        // Type 0007h = UNSIGNED32, 4 bytes; the printed C8 decodes as 200.168.0.244
        // (protocol notes §5.2).
        assert_eq!(typed.dtype_code, 0x0007);
        assert_eq!(
            u32::from_le_bytes(typed.data.clone().try_into().unwrap()),
            0xC8A8_00F4
        );
        // What the simulated adapter sends for 192.168.0.244.
        let ours = Typed {
            dtype_code: 0x0007,
            data: 0xC0A8_00F4u32.to_le_bytes().to_vec(),
        };
        assert_eq!(
            Reply::success(0x34, ours.encode()).encode(),
            bytes("B4 00 00 00 07 00 04 00 F4 00 A8 C0")
        );
        assert!(Typed::decode(&bytes("07 00 04 00 F4 00")).is_err(), "short");
        assert!(Typed::decode(&bytes("07 00 01 00 F4 00")).is_err(), "long");
    }
}
