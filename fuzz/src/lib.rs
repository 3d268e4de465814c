//! What the fuzz targets share: the operation stream they decode their input into, the in-session header
//! they can put in front of fuzzed bytes, and the check that everything a core emits parses.

pub mod sessions;

/// Splits fuzz input into operations `[op] [len_lo] [len_hi] [len bytes]` (a length past the end takes
/// what is left).
pub fn ops(data: &[u8]) -> impl Iterator<Item = (u8, &[u8])> {
    let mut rest = data;
    std::iter::from_fn(move || {
        let [op, lo, hi, tail @ ..] = rest else { return None };
        let len = usize::from(u16::from_le_bytes([*lo, *hi])).min(tail.len());
        let (bytes, next) = tail.split_at(len);
        rest = next;
        Some((*op, bytes))
    })
}

/// `bytes` as a message of session 0x81: stream id and sequence number taken from its first two bytes, so
/// the fuzzer reaches stream and submessage handling.
pub fn in_session(bytes: &[u8]) -> Vec<u8> {
    let mut m = vec![0x81, bytes.first().copied().unwrap_or(0), bytes.get(1).copied().unwrap_or(0), 0];
    m.extend_from_slice(bytes.get(2..).unwrap_or(&[]));
    m
}

/// Panics unless `msg` has a valid header and every submessage decodes (FRAGMENT payloads are opaque).
pub fn assert_parses(msg: &[u8], who: &str) {
    let (_, subs) = xrce_proto::message::parse(msg).unwrap_or_else(|e| panic!("{who} header: {e:?}"));
    for s in subs {
        let s = s.unwrap_or_else(|e| panic!("{who} framing: {e:?}"));
        if s.header.id != xrce_proto::submessage::id::FRAGMENT {
            s.decode().unwrap_or_else(|e| panic!("{who} submessage: {e:?}"));
        }
    }
}
