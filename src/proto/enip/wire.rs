//! The byte rules of EtherNet/IP in one place: every field little-endian, except the
//! socket addresses of sockaddr info and identity items, which are big-endian (network
//! order, as in BSD `sockaddr_in`). Decoders read through [`Reader`], which names the
//! field that was short instead of panicking.

use std::fmt;

/// Bytes from the network that do not decode.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("{what}: {field} needs {need} more bytes, {got} left")]
    Short {
        what: &'static str,
        field: &'static str,
        need: usize,
        got: usize,
    },
    #[error("{what}: {reason}")]
    Invalid { what: &'static str, reason: String },
}

impl DecodeError {
    pub fn invalid(what: &'static str, reason: impl fmt::Display) -> Self {
        DecodeError::Invalid {
            what,
            reason: reason.to_string(),
        }
    }
}

/// A cursor over received bytes.
#[derive(Clone, Debug)]
pub struct Reader<'a> {
    what: &'static str,
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// `what` names the structure for error messages ("Forward_Open request").
    pub fn new(what: &'static str, bytes: &'a [u8]) -> Self {
        Self { what, bytes, at: 0 }
    }

    pub fn what(&self) -> &'static str {
        self.what
    }

    /// How many bytes have been read.
    pub fn position(&self) -> usize {
        self.at
    }

    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }

    pub fn take(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], DecodeError> {
        if self.remaining() < n {
            return Err(DecodeError::Short {
                what: self.what,
                field,
                need: n,
                got: self.remaining(),
            });
        }
        let out = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], DecodeError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, field)?);
        Ok(out)
    }

    pub fn u8(&mut self, field: &'static str) -> Result<u8, DecodeError> {
        Ok(self.array::<1>(field)?[0])
    }

    pub fn u16(&mut self, field: &'static str) -> Result<u16, DecodeError> {
        Ok(u16::from_le_bytes(self.array(field)?))
    }

    pub fn u32(&mut self, field: &'static str) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(self.array(field)?))
    }

    pub fn i16(&mut self, field: &'static str) -> Result<i16, DecodeError> {
        Ok(i16::from_le_bytes(self.array(field)?))
    }

    pub fn i32(&mut self, field: &'static str) -> Result<i32, DecodeError> {
        Ok(i32::from_le_bytes(self.array(field)?))
    }

    /// A big-endian field (socket addresses only).
    pub fn u16_be(&mut self, field: &'static str) -> Result<u16, DecodeError> {
        Ok(u16::from_be_bytes(self.array(field)?))
    }

    /// A big-endian field (socket addresses only).
    pub fn u32_be(&mut self, field: &'static str) -> Result<u32, DecodeError> {
        Ok(u32::from_be_bytes(self.array(field)?))
    }

    /// Everything not read yet.
    pub fn rest(&mut self) -> &'a [u8] {
        let out = &self.bytes[self.at..];
        self.at = self.bytes.len();
        out
    }

    /// Fail when bytes are left over.
    pub fn end(&self) -> Result<(), DecodeError> {
        match self.remaining() {
            0 => Ok(()),
            n => Err(DecodeError::invalid(
                self.what,
                format!("{n} bytes more than the structure holds"),
            )),
        }
    }
}

/// Appending fields in the wire's byte order.
pub trait Put {
    fn put_u8(&mut self, v: u8);
    fn put_u16(&mut self, v: u16);
    fn put_u32(&mut self, v: u32);
    fn put_u16_be(&mut self, v: u16);
    fn put_u32_be(&mut self, v: u32);
}

impl Put for Vec<u8> {
    fn put_u8(&mut self, v: u8) {
        self.push(v);
    }
    fn put_u16(&mut self, v: u16) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_u32(&mut self, v: u32) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_u16_be(&mut self, v: u16) {
        self.extend_from_slice(&v.to_be_bytes());
    }
    fn put_u32_be(&mut self, v: u32) {
        self.extend_from_slice(&v.to_be_bytes());
    }
}

pub use crate::number::hex;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_little_endian_and_sockaddrs_big_endian() {
        let bytes = [0x34, 0x12, 0x78, 0x56, 0x34, 0x12, 0x08, 0xAE];
        let mut r = Reader::new("test", &bytes);
        assert_eq!(r.u16("a"), Ok(0x1234));
        assert_eq!(r.u32("b"), Ok(0x1234_5678));
        assert_eq!(r.u16_be("port"), Ok(2222));
        r.end().expect("all read");
        let mut out = Vec::new();
        out.put_u16(0x1234);
        out.put_u32(0x1234_5678);
        out.put_u16_be(2222);
        assert_eq!(out, bytes);
    }

    #[test]
    fn a_short_field_is_named() {
        let mut r = Reader::new("header", &[1, 2, 3]);
        assert_eq!(
            r.u32("session handle").unwrap_err().to_string(),
            "header: session handle needs 4 more bytes, 3 left"
        );
        assert_eq!(r.remaining(), 3, "nothing consumed");
        r.take(2, "x").expect("two");
        assert!(r.end().unwrap_err().to_string().contains("1 bytes more"));
    }

    #[test]
    fn hex_is_spaced() {
        assert_eq!(hex(&[0x32, 0x02, 0x20]), "32 02 20");
        assert_eq!(hex(&[]), "");
    }
}
