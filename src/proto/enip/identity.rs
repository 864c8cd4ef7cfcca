//! The identity an adapter announces in its ListIdentity reply (CPF item 0Ch) and holds
//! in the Identity object (class 01h, instance 1).

use std::net::{Ipv4Addr, SocketAddrV4};

use super::cpf::{self, Item, SockAddr};
use super::encap::{Command, Packet};
use super::wire::{DecodeError, Put, Reader};

/// Nanotec's ODVA vendor id: 1368 (558h), "Nanotec Electronic GmbH & Co. KG" in ODVA's
/// vendor list (as pycomm3's copy of it has it). Not the CiA vendor id 26Ch of 1018h:01,
/// which ODVA assigns to Parker Hannifin/Compumotor.
pub const NANOTEC_VENDOR: u16 = 0x0558;

/// The Identity object's state attribute, in words.
pub fn state_text(state: u8) -> &'static str {
    match state {
        0 => "nonexistent",
        1 => "self testing",
        2 => "standby",
        3 => "operational",
        4 => "major recoverable fault",
        5 => "major unrecoverable fault",
        255 => "default",
        _ => "reserved state",
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    /// Encapsulation protocol version (1).
    pub encap_version: u16,
    /// Where the adapter takes explicit messages.
    pub socket: SockAddr,
    pub vendor: u16,
    pub device_type: u16,
    pub product_code: u16,
    pub revision: (u8, u8),
    pub status: u16,
    pub serial: u32,
    pub product_name: String,
    pub state: u8,
}

impl Identity {
    pub fn decode(data: &[u8]) -> Result<Identity, DecodeError> {
        let mut r = Reader::new("ListIdentity item", data);
        let encap_version = r.u16("encapsulation version")?;
        let socket = SockAddr::decode(&mut r)?;
        let vendor = r.u16("vendor id")?;
        let device_type = r.u16("device type")?;
        let product_code = r.u16("product code")?;
        let major = r.u8("major revision")?;
        let minor = r.u8("minor revision")?;
        let status = r.u16("status")?;
        let serial = r.u32("serial number")?;
        let length = r.u8("product name length")?;
        let name = r.take(usize::from(length), "product name")?;
        // A device that leaves the state out is still identified.
        let state = if r.remaining() > 0 {
            r.u8("state")?
        } else {
            255
        };
        Ok(Identity {
            encap_version,
            socket,
            vendor,
            device_type,
            product_code,
            revision: (major, minor),
            status,
            serial,
            product_name: String::from_utf8_lossy(name)
                .trim_end_matches('\0')
                .to_owned(),
            state,
        })
    }

    pub fn encode_into(&self, out: &mut Vec<u8>) {
        out.put_u16(self.encap_version);
        self.socket.encode_into(out);
        self.encode_attributes(out);
        out.put_u8(self.state);
    }

    /// Attributes 1 to 7 as Get_Attributes_All of the Identity object returns them.
    pub fn encode_attributes(&self, out: &mut Vec<u8>) {
        out.put_u16(self.vendor);
        out.put_u16(self.device_type);
        out.put_u16(self.product_code);
        out.put_u8(self.revision.0);
        out.put_u8(self.revision.1);
        out.put_u16(self.status);
        out.put_u32(self.serial);
        let name = &self.product_name.as_bytes()[..self.product_name.len().min(32)];
        out.put_u8(name.len() as u8);
        out.extend_from_slice(name);
    }

    /// The adapter's IP: the sockaddr's, or where the reply came from when that is 0.0.0.0.
    pub fn address(&self, from: Option<Ipv4Addr>) -> SocketAddrV4 {
        let announced = self.socket.socket();
        match (announced.ip().is_unspecified(), from) {
            (true, Some(ip)) => SocketAddrV4::new(ip, announced.port()),
            _ => announced,
        }
    }
}

/// The identities in a ListIdentity reply datagram.
pub fn decode_list_identity_reply(bytes: &[u8]) -> Vec<Identity> {
    let Ok(packet) = Packet::decode(bytes) else {
        return vec![];
    };
    if packet.command != Command::LIST_IDENTITY {
        return vec![];
    }
    cpf::decode(&packet.data)
        .unwrap_or_default()
        .into_iter()
        .filter_map(|i| match i {
            Item::Identity(identity) => Some(*identity),
            _ => None,
        })
        .collect()
}

/// For tests: a Nanotec PD4-E, revision 2.5, that announces 0.0.0.0:44818 (so its address
/// is where its reply came from).
#[cfg(test)]
pub(crate) fn unaddressed_sample() -> Identity {
    Identity {
        encap_version: 1,
        socket: SockAddr::new(SocketAddrV4::new(Ipv4Addr::UNSPECIFIED, 44818)),
        vendor: 0x558,
        device_type: 0x2B,
        product_code: 7,
        revision: (2, 5),
        status: 0,
        serial: 99,
        product_name: "PD4-E".into(),
        state: 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reply_datagram_lists_its_identities() {
        let identity = unaddressed_sample();
        let mut data = vec![];
        cpf::encode(&[Item::Identity(Box::new(identity.clone()))], &mut data);
        let bytes = Packet::new(Command::LIST_IDENTITY, 0, [0; 8], data).encode();
        assert_eq!(decode_list_identity_reply(&bytes), vec![identity.clone()]);
        assert!(decode_list_identity_reply(&bytes[..30]).is_empty());
    }

    fn sample() -> Identity {
        Identity {
            encap_version: 1,
            socket: SockAddr::new("192.168.2.100:44818".parse().unwrap()),
            vendor: NANOTEC_VENDOR,
            device_type: 0x2B,
            product_code: 0x0101,
            revision: (1, 2),
            status: 0x0030,
            serial: 0x1234_5678,
            product_name: "C5-E-1-21".into(),
            state: 3,
        }
    }

    #[test]
    fn the_identity_item_round_trips_with_the_documented_layout() {
        let mut out = Vec::new();
        sample().encode_into(&mut out);
        assert_eq!(&out[0..2], &[0x01, 0x00]);
        // sockaddr big-endian: family 2, port 44818 = AF12h.
        assert_eq!(&out[2..8], &[0x00, 0x02, 0xAF, 0x12, 192, 168]);
        // vendor 558h little-endian right after the 16-byte sockaddr.
        assert_eq!(&out[18..20], &[0x58, 0x05]);
        assert_eq!(out[32], 9, "name length");
        assert_eq!(out.last(), Some(&3), "state");
        assert_eq!(Identity::decode(&out), Ok(sample()));
    }

    #[test]
    fn a_missing_state_or_a_zero_address_are_tolerated() {
        let mut out = Vec::new();
        let mut id = sample();
        id.socket = SockAddr::new("0.0.0.0:44818".parse().unwrap());
        id.encode_into(&mut out);
        out.pop();
        let back = Identity::decode(&out).expect("no state");
        assert_eq!(back.state, 255);
        assert_eq!(
            back.address(Some(Ipv4Addr::new(10, 0, 0, 7))),
            "10.0.0.7:44818".parse().unwrap()
        );
        assert!(Identity::decode(&out[..30]).is_err());
    }
}
