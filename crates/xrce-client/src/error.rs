//! Errors of the client.

use core::fmt;

use crate::transport::TransportError;

/// Why an operation failed.
///
/// The C client answers most of these with a request id of 0 or a silent drop; here each has its own variant so
/// the caller can act (run the session and retry on [`Error::WouldBlock`], split the data on
/// [`Error::TooLarge`], and so on).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// The output stream has no room now (reliable history full of unacknowledged messages, or best-effort
    /// buffer already holding data): run the session so the agent acknowledges or the buffer is sent, then retry.
    WouldBlock,
    /// The data can never fit: larger than the MTU on a best-effort stream, than the whole history on a
    /// reliable one, or than a submessage (65535 bytes) outside the continuous fragmented API.
    TooLarge,
    /// No stream with this id was created in this session.
    UnknownStream,
    /// The stream limit given by the session's const parameters is reached (`CONFIG_MAX_*_STREAMS`).
    TooManyStreams,
    /// The history is not a power of two dividing the buffer, or slots are too small for a message.
    InvalidHistory,
    /// The operation needs an established session.
    NotConnected,
    /// The agent refused the session with this status.
    Refused(u8),
    /// No answer in time.
    Timeout,
    /// A continuous fragmented write is in progress on this stream.
    Busy,
    /// An encoding failed (a value out of range).
    Encode(xrce_proto::cdr::Error),
    /// The transport failed.
    Transport(TransportError),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::WouldBlock => f.write_str("output stream full: run the session and retry"),
            Self::TooLarge => f.write_str("data larger than the stream can ever carry"),
            Self::UnknownStream => f.write_str("no such stream in this session"),
            Self::TooManyStreams => f.write_str("stream limit of the session reached"),
            Self::InvalidHistory => f.write_str("history must be a power of two dividing the buffer"),
            Self::NotConnected => f.write_str("session not established"),
            Self::Refused(s) => write!(f, "agent refused the session with status {s:#04x}"),
            Self::Timeout => f.write_str("no answer from the agent in time"),
            Self::Busy => f.write_str("a continuous fragmented write is in progress on this stream"),
            Self::Encode(e) => write!(f, "encoding failed: {e}"),
            Self::Transport(e) => write!(f, "transport failed: {e}"),
        }
    }
}

impl core::error::Error for Error {}

impl From<xrce_proto::cdr::Error> for Error {
    fn from(e: xrce_proto::cdr::Error) -> Self {
        Self::Encode(e)
    }
}

impl From<TransportError> for Error {
    fn from(e: TransportError) -> Self {
        Self::Transport(e)
    }
}

/// Result of client operations.
pub type Result<T> = core::result::Result<T, Error>;
