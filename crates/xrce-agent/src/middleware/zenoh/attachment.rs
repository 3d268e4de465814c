//! The attachment rmw_zenoh puts on every sample, query and reply, and reads from them: the sample's
//! sequence number, its source time and the GID of the endpoint that sent it, in zenoh-ext's serializer
//! format (two little-endian i64, then the 16 GID bytes after their length, 16 as one LEB128 byte): 33 bytes.

/// The GID length (rmw's `RMW_GID_STORAGE_SIZE`).
pub const GID_LEN: usize = 16;

/// Bytes of an encoded attachment.
pub const ENCODED_LEN: usize = 8 + 8 + 1 + GID_LEN;

/// What an attachment carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attachment {
    /// Per endpoint, from 1. A reply carries its request's.
    pub sequence_number: i64,
    /// When the sample was sent, in nanoseconds since the Unix epoch.
    pub source_timestamp: i64,
    /// The sending endpoint's GID; a reply carries its client's.
    pub gid: [u8; GID_LEN],
}

impl Attachment {
    /// The bytes rmw_zenoh reads.
    pub fn encode(&self) -> [u8; ENCODED_LEN] {
        let (seq, time) = (self.sequence_number.to_le_bytes(), self.source_timestamp.to_le_bytes());
        let gid_len = [GID_LEN as u8];
        let mut out = [0u8; ENCODED_LEN];
        let fields = seq.iter().chain(&time).chain(&gid_len).chain(&self.gid);
        for (o, b) in out.iter_mut().zip(fields) {
            *o = *b;
        }
        out
    }

    /// Reads what rmw_zenoh (or anyone following it) sent; `None` when it is not that layout.
    pub fn decode(bytes: &[u8]) -> Option<Self> {
        let seq = bytes.get(..8)?;
        let time = bytes.get(8..16)?;
        if *bytes.get(16)? as usize != GID_LEN || bytes.len() != ENCODED_LEN {
            return None;
        }
        Some(Self {
            sequence_number: i64::from_le_bytes(seq.try_into().ok()?),
            source_timestamp: i64::from_le_bytes(time.try_into().ok()?),
            gid: bytes.get(17..)?.try_into().ok()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_sample_attachment_is_33_bytes_as_rmw_zenoh_sends_it() {
        let gid: [u8; 16] = core::array::from_fn(|i| i as u8 + 0xa0);
        let a = Attachment { sequence_number: 1, source_timestamp: 0x0102_0304_0506_0708, gid };
        let bytes = a.encode();
        assert_eq!(bytes.len(), 33);
        assert_eq!(&bytes[..8], &[1, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(&bytes[8..16], &[8, 7, 6, 5, 4, 3, 2, 1]);
        assert_eq!(bytes[16], 0x10);
        assert_eq!(&bytes[17..], &gid);
        assert_eq!(Attachment::decode(&bytes), Some(a));
    }

    #[test]
    fn other_layouts_are_refused() {
        let bytes = Attachment { sequence_number: 5, source_timestamp: 6, gid: [7; 16] }.encode();
        assert_eq!(Attachment::decode(&bytes[..32]), None);
        let mut wrong_len = bytes;
        wrong_len[16] = 12;
        assert_eq!(Attachment::decode(&wrong_len), None);
        let mut longer = bytes.to_vec();
        longer.push(0);
        assert_eq!(Attachment::decode(&longer), None);
    }
}
