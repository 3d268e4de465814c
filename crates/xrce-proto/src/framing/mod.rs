//! Byte-stream and datagram framings that carry XRCE messages.
