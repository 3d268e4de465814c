//! Best-effort output stream (spec §9.2): submessages accumulate in one buffer that a flush sends as one
//! message with the next sequence number.

use super::{copy_parts, parts_total, seq, SUBHEADER};
use crate::error::{Error, Result};
use xrce_proto::layout::submessage_offset;
use xrce_proto::{ClientKey, StreamId};

/// A best-effort output stream over a caller's buffer.
#[derive(Debug)]
pub struct OutputBestEffort<'a> {
    buf: &'a mut [u8],
    /// Usable bytes: the smaller of the buffer and the transport MTU.
    capacity: usize,
    header_size: usize,
    /// Message bytes written (header space included); 0 when empty.
    len: usize,
    last_sent: u16,
    flush: bool,
}

impl<'a> OutputBestEffort<'a> {
    /// A stream writing into `buf`, with messages of at most `mtu` bytes and headers of `header_size` bytes.
    pub fn new(buf: &'a mut [u8], mtu: usize, header_size: usize) -> Self {
        let capacity = buf.len().min(mtu);
        Self { buf, capacity, header_size, len: 0, last_sent: seq::INIT, flush: false }
    }

    /// Forgets buffered data and restarts numbering (session (re)creation).
    pub fn reset(&mut self) {
        self.len = 0;
        self.last_sent = seq::INIT;
        self.flush = false;
    }

    /// Whether data waits to be sent.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn start(&self) -> usize {
        if self.len == 0 {
            self.header_size
        } else {
            submessage_offset(self.len)
        }
    }

    /// Reserves room for a submessage of `total` bytes (header included) and returns it, zero-filled.
    ///
    /// [`Error::TooLarge`] when it would not fit even an empty message (larger than the MTU), and
    /// [`Error::WouldBlock`] when it would fit once the current content is sent.
    pub fn reserve(&mut self, total: usize) -> Result<&mut [u8]> {
        if self.header_size + total > self.capacity {
            return Err(Error::TooLarge);
        }
        let start = self.start();
        let end = start + total;
        if end > self.capacity {
            return Err(Error::WouldBlock);
        }
        // The padding after the content (the header's room when empty) and the region zeroed in one go (firmware
        // size); both fit: `end <= capacity <= buf.len()`.
        if let Some(zeroed) = self.buf.get_mut(self.len..end) {
            zeroed.fill(0);
        }
        self.len = end;
        self.buf.get_mut(start..end).ok_or(Error::TooLarge)
    }

    /// Appends a submessage made of `parts` (its 4-byte header first).
    pub fn write_parts(&mut self, parts: &[&[u8]]) -> Result<()> {
        let total = parts_total(parts);
        if total < SUBHEADER {
            return Err(Error::Encode(xrce_proto::cdr::Error::Truncated));
        }
        let region = self.reserve(total)?;
        copy_parts(region, parts);
        Ok(())
    }

    /// Marks the buffered data for sending (`flash`).
    pub fn flush(&mut self) {
        self.flush = self.len > 0;
    }

    /// The message to send now, if flushed: header stamped with the next sequence number, padded to 4 as the C
    /// client does. Returns its length in `out`.
    pub fn poll_transmit(&mut self, session_id: u8, key: ClientKey, stream: StreamId, out: &mut [u8]) -> Option<usize> {
        if !self.flush || self.len == 0 {
            return None;
        }
        let len = submessage_offset(self.len);
        let seq_nr = self.last_sent.wrapping_add(1);
        super::emit(out, session_id, key, stream, seq_nr, self.buf, self.len, len)?;
        self.last_sent = seq_nr;
        self.len = 0;
        self.flush = false;
        Some(len)
    }
}
