//! The Common Packet Format (protocol notes §3.2): an item count, then items of
//! `type u16 | length u16 | data`.

use std::net::{Ipv4Addr, SocketAddrV4};

use super::identity::Identity;
use super::wire::{DecodeError, Put, Reader};

pub const NULL_ADDRESS: u16 = 0x0000;
pub const LIST_IDENTITY: u16 = 0x000C;
pub const CONNECTED_ADDRESS: u16 = 0x00A1;
pub const CONNECTED_DATA: u16 = 0x00B1;
pub const UNCONNECTED_DATA: u16 = 0x00B2;
pub const LIST_SERVICES: u16 = 0x0100;
pub const SOCKADDR_OT: u16 = 0x8000;
pub const SOCKADDR_TO: u16 = 0x8001;
pub const SEQUENCED_ADDRESS: u16 = 0x8002;

/// The most items drivedeck reads from one packet; real packets have two to four.
const MAX_ITEMS: u16 = 16;

/// A `sockaddr_in` as CPF carries it: 16 bytes, big-endian, the last 8 zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SockAddr {
    /// 2 (AF_INET).
    pub family: u16,
    pub port: u16,
    pub ip: Ipv4Addr,
}

impl SockAddr {
    pub const LEN: usize = 16;

    pub fn new(addr: SocketAddrV4) -> SockAddr {
        SockAddr {
            family: 2,
            port: addr.port(),
            ip: *addr.ip(),
        }
    }

    pub fn socket(&self) -> SocketAddrV4 {
        SocketAddrV4::new(self.ip, self.port)
    }

    pub fn encode_into(&self, out: &mut Vec<u8>) {
        out.put_u16_be(self.family);
        out.put_u16_be(self.port);
        out.put_u32_be(u32::from(self.ip));
        out.extend_from_slice(&[0; 8]);
    }

    pub fn decode(r: &mut Reader<'_>) -> Result<SockAddr, DecodeError> {
        let family = r.u16_be("sin_family")?;
        let port = r.u16_be("sin_port")?;
        let ip = Ipv4Addr::from(r.u32_be("sin_addr")?);
        r.take(8, "sin_zero")?;
        Ok(SockAddr { family, port, ip })
    }
}

/// One CPF item.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Item {
    Null,
    /// The connection id of a connected message.
    ConnectedAddress(u32),
    /// Class 0/1 I/O: connection id and encapsulation sequence number.
    SequencedAddress {
        connection: u32,
        sequence: u32,
    },
    /// A Message Router request or reply.
    UnconnectedData(Vec<u8>),
    /// Class 3: a sequence count and a Message Router request or reply; class 1: the I/O
    /// data (sequence count, run/idle header, assembly).
    ConnectedData(Vec<u8>),
    SockaddrOt(SockAddr),
    SockaddrTo(SockAddr),
    Identity(Box<Identity>),
    /// Any other item, kept as it came.
    Other {
        kind: u16,
        data: Vec<u8>,
    },
}

impl Item {
    pub fn kind(&self) -> u16 {
        match self {
            Item::Null => NULL_ADDRESS,
            Item::ConnectedAddress(_) => CONNECTED_ADDRESS,
            Item::SequencedAddress { .. } => SEQUENCED_ADDRESS,
            Item::UnconnectedData(_) => UNCONNECTED_DATA,
            Item::ConnectedData(_) => CONNECTED_DATA,
            Item::SockaddrOt(_) => SOCKADDR_OT,
            Item::SockaddrTo(_) => SOCKADDR_TO,
            Item::Identity(_) => LIST_IDENTITY,
            Item::Other { kind, .. } => *kind,
        }
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        out.put_u16(self.kind());
        let length_at = out.len();
        out.put_u16(0);
        match self {
            Item::Null => {}
            Item::ConnectedAddress(id) => out.put_u32(*id),
            Item::SequencedAddress {
                connection,
                sequence,
            } => {
                out.put_u32(*connection);
                out.put_u32(*sequence);
            }
            Item::UnconnectedData(d) | Item::ConnectedData(d) | Item::Other { data: d, .. } => {
                out.extend_from_slice(d)
            }
            Item::SockaddrOt(s) | Item::SockaddrTo(s) => s.encode_into(out),
            Item::Identity(identity) => identity.encode_into(out),
        }
        let length = (out.len() - length_at - 2).min(usize::from(u16::MAX)) as u16;
        out[length_at..length_at + 2].copy_from_slice(&length.to_le_bytes());
    }

    fn decode(kind: u16, data: &[u8]) -> Result<Item, DecodeError> {
        let exact = |n: usize, name: &'static str| {
            if data.len() == n {
                Ok(())
            } else {
                Err(DecodeError::invalid(
                    name,
                    format!("the item is {} bytes long, it must be {n}", data.len()),
                ))
            }
        };
        Ok(match kind {
            NULL_ADDRESS => {
                exact(0, "null address item")?;
                Item::Null
            }
            CONNECTED_ADDRESS => {
                exact(4, "connected address item")?;
                Item::ConnectedAddress(Reader::new("connected address item", data).u32("id")?)
            }
            SEQUENCED_ADDRESS => {
                exact(8, "sequenced address item")?;
                let mut r = Reader::new("sequenced address item", data);
                Item::SequencedAddress {
                    connection: r.u32("connection id")?,
                    sequence: r.u32("sequence number")?,
                }
            }
            UNCONNECTED_DATA => Item::UnconnectedData(data.to_vec()),
            CONNECTED_DATA => Item::ConnectedData(data.to_vec()),
            SOCKADDR_OT | SOCKADDR_TO => {
                exact(SockAddr::LEN, "sockaddr info item")?;
                let s = SockAddr::decode(&mut Reader::new("sockaddr info item", data))?;
                if kind == SOCKADDR_OT {
                    Item::SockaddrOt(s)
                } else {
                    Item::SockaddrTo(s)
                }
            }
            LIST_IDENTITY => Item::Identity(Box::new(Identity::decode(data)?)),
            kind => Item::Other {
                kind,
                data: data.to_vec(),
            },
        })
    }
}

/// Append the item count and the items.
pub fn encode(items: &[Item], out: &mut Vec<u8>) {
    out.put_u16(items.len() as u16);
    for item in items {
        item.encode_into(out);
    }
}

/// Items from the bytes of a packet; every byte must belong to an item.
pub fn decode(bytes: &[u8]) -> Result<Vec<Item>, DecodeError> {
    let mut r = Reader::new("common packet format", bytes);
    let count = r.u16("item count")?;
    if count > MAX_ITEMS {
        return Err(DecodeError::invalid(
            "common packet format",
            format!("{count} items (at most {MAX_ITEMS} expected)"),
        ));
    }
    let mut items = Vec::with_capacity(usize::from(count));
    for _ in 0..count {
        let kind = r.u16("item type")?;
        let length = r.u16("item length")?;
        let data = r.take(usize::from(length), "item data")?;
        items.push(Item::decode(kind, data)?);
    }
    r.end()?;
    Ok(items)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unconnected_request_is_a_null_address_and_a_data_item() {
        let mut out = Vec::new();
        encode(
            &[Item::Null, Item::UnconnectedData(vec![0x32, 0x02])],
            &mut out,
        );
        assert_eq!(
            out,
            [
                0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0xB2, 0x00, 0x02, 0x00, 0x32, 0x02
            ]
        );
        assert_eq!(
            decode(&out),
            Ok(vec![Item::Null, Item::UnconnectedData(vec![0x32, 0x02])])
        );
    }

    #[test]
    fn sockaddr_is_big_endian_with_eight_zero_bytes() {
        let item = Item::SockaddrTo(SockAddr::new("192.168.2.100:2222".parse().unwrap()));
        let mut out = Vec::new();
        encode(std::slice::from_ref(&item), &mut out);
        assert_eq!(
            out,
            [
                0x01, 0x00, 0x01, 0x80, 0x10, 0x00, 0x00, 0x02, 0x08, 0xAE, 192, 168, 2, 100, 0, 0,
                0, 0, 0, 0, 0, 0
            ]
        );
        assert_eq!(decode(&out), Ok(vec![item]));
    }

    #[test]
    fn the_sequenced_address_item_of_class_1() {
        let mut out = Vec::new();
        let items = [
            Item::SequencedAddress {
                connection: 0x1122_3344,
                sequence: 7,
            },
            Item::ConnectedData(vec![1, 0]),
        ];
        encode(&items, &mut out);
        assert_eq!(
            out,
            [
                0x02, 0x00, 0x02, 0x80, 0x08, 0x00, 0x44, 0x33, 0x22, 0x11, 0x07, 0x00, 0x00, 0x00,
                0xB1, 0x00, 0x02, 0x00, 0x01, 0x00
            ]
        );
        assert_eq!(decode(&out).unwrap(), items);
    }

    #[test]
    fn bad_item_lists_are_refused_by_name() {
        // An item longer than the packet.
        assert!(
            decode(&[0x01, 0x00, 0xB2, 0x00, 0x09, 0x00, 0x01])
                .unwrap_err()
                .to_string()
                .contains("item data needs 9")
        );
        // A connected address of the wrong size.
        assert!(
            decode(&[0x01, 0x00, 0xA1, 0x00, 0x02, 0x00, 0x01, 0x02])
                .unwrap_err()
                .to_string()
                .contains("must be 4")
        );
        // Trailing bytes after the last item.
        assert!(decode(&[0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0xFF]).is_err());
        // Absurd item counts.
        assert!(decode(&[0xFF, 0xFF]).is_err());
        // Unknown items are kept.
        assert_eq!(
            decode(&[0x01, 0x00, 0x34, 0x12, 0x01, 0x00, 0xAA]),
            Ok(vec![Item::Other {
                kind: 0x1234,
                data: vec![0xAA]
            }])
        );
    }
}
