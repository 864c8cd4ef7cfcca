//! FC 101: the whole object dictionary in frames (Nanotec).

use super::{PduError, Reader};

// ---------------------------------------------------------------------------------------------
// FC 101: read the complete object dictionary.

/// One "object dictionary frame" of an FC 101/102 response (NT-FC101):
/// `idxLo idxHi sub nbytes data…`, the one little-endian header in Modbus.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct DictionaryFrame {
    pub index: u16,
    pub subindex: u8,
    /// The object value, little-endian, `nbytes` long.
    pub data: Vec<u8>,
}

impl DictionaryFrame {
    pub(super) fn encode_into(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.index.to_le_bytes());
        out.push(self.subindex);
        out.push(u8::try_from(self.data.len()).unwrap_or(u8::MAX));
        out.extend_from_slice(&self.data);
    }

    pub(super) fn decode_all(function: u8, bytes: &[u8]) -> Result<Vec<Self>, PduError> {
        let mut r = Reader {
            function,
            bytes,
            pos: 0,
        };
        let mut frames = Vec::new();
        while r.remaining() > 0 {
            let index = r.take(2, "object frame index")?;
            let subindex = r.u8("object frame subindex")?;
            let len = r.u8("object frame length")?;
            let data = r.take(usize::from(len), "object frame data")?.to_vec();
            frames.push(Self {
                index: u16::from_le_bytes([index[0], index[1]]),
                subindex,
                data,
            });
        }
        Ok(frames)
    }
}
