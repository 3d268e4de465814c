//! The named fields of `uxrSession` (core/session/session.h and the stream headers), field for field: what
//! programs read and write. build.rs checks every offset against the header.

#![allow(non_camel_case_types)]

use core::ffi::c_void;

use super::hooks::{OnReply, OnRequest, OnStatus, OnTime, OnTopic};
use crate::abi::uxrStreamId;
use crate::comm::uxrCommunication;

/// `UXR_STATUS_NONE`.
pub const STATUS_NONE: u8 = 0xFF;
/// `NO_PONG_STATUS`.
pub const NO_PONG: u8 = 0;
/// `PONG_IN_SESSION_STATUS`.
pub const PONG_IN_SESSION: u8 = 1;
/// `PONG_NO_SESSION_STATUS`.
pub const PONG_NO_SESSION: u8 = 2;

/// `uxrSessionInfo`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct uxrSessionInfo {
    /// Session id.
    pub id: u8,
    /// Client key, most significant byte first.
    pub key: [u8; 4],
    /// Status of the last create or delete.
    pub last_requested_status: u8,
    /// Last request id given out.
    pub last_request_id: u16,
}

/// `uxrReliableStream`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct uxrReliableStream {
    /// The memory lent.
    pub buffer: *mut u8,
    /// Its size.
    pub size: usize,
    /// Slots.
    pub history: u16,
}

/// `uxrOutputBestEffortStream`.
#[repr(C)]
#[derive(Debug)]
pub struct uxrOutputBestEffortStream {
    /// The memory lent.
    pub buffer: *mut u8,
    /// eProsima's write position (0 here).
    pub writer: usize,
    /// Size of the memory.
    pub size: usize,
    /// eProsima's header offset (0 here).
    pub offset: u8,
    /// eProsima's last sequence number (0 here).
    pub last_send: u16,
    /// Its lock (multithread profile).
    #[cfg(uxr_multithread)]
    pub mutex: crate::lock::uxrMutex,
}

/// `uxrOutputReliableStream`.
#[repr(C)]
#[derive(Debug)]
pub struct uxrOutputReliableStream {
    /// Memory and history.
    pub base: uxrReliableStream,
    /// eProsima's engine state, 0 here (the library's own engine runs the stream).
    pub offset: u8,
    /// As `offset`.
    pub last_written: u16,
    /// As `offset`.
    pub last_sent: u16,
    /// As `offset`.
    pub last_acknown: u16,
    /// As `offset`.
    pub next_heartbeat_timestamp: i64,
    /// As `offset`.
    pub next_heartbeat_tries: u8,
    /// As `offset`.
    pub send_lost: bool,
    /// Its lock (multithread profile).
    #[cfg(uxr_multithread)]
    pub mutex: crate::lock::uxrMutex,
}

/// `uxrInputBestEffortStream`.
#[repr(C)]
#[derive(Debug)]
pub struct uxrInputBestEffortStream {
    /// eProsima's engine state, 0 here.
    pub last_handled: u16,
    /// Its lock (multithread profile).
    #[cfg(uxr_multithread)]
    pub mutex: crate::lock::uxrMutex,
}

/// `uxrInputReliableStream`.
#[repr(C)]
#[derive(Debug)]
pub struct uxrInputReliableStream {
    /// Memory and history.
    pub base: uxrReliableStream,
    /// eProsima's engine state, 0 here.
    pub last_handled: u16,
    /// As `last_handled`.
    pub last_announced: u16,
    /// As `last_handled` (null).
    pub on_get_fragmentation_info: Option<unsafe extern "C" fn(*mut u8) -> u32>,
    /// As `last_handled`.
    pub cleanup_flag: bool,
    /// Its lock (multithread profile).
    #[cfg(uxr_multithread)]
    pub mutex: crate::lock::uxrMutex,
}

/// `uxrStreamStorage` with one stream of each kind (`UXR_CONFIG_MAX_*_STREAMS`).
#[repr(C)]
#[derive(Debug)]
pub struct uxrStreamStorage {
    /// Output best-effort streams.
    pub output_best_effort: [uxrOutputBestEffortStream; super::OBE],
    /// How many exist.
    pub output_best_effort_size: u8,
    /// Output reliable streams.
    pub output_reliable: [uxrOutputReliableStream; super::ORE],
    /// How many exist.
    pub output_reliable_size: u8,
    /// Input best-effort streams.
    pub input_best_effort: [uxrInputBestEffortStream; super::IBE],
    /// How many exist.
    pub input_best_effort_size: u8,
    /// Input reliable streams.
    pub input_reliable: [uxrInputReliableStream; super::IRE],
    /// How many exist.
    pub input_reliable_size: u8,
}

/// `uxrOnBuffersFull` (eProsima's: session and the program's args).
pub type OnBuffersFull = Option<unsafe extern "C" fn(*mut uxrSession, *mut c_void) -> bool>;

/// `uxrContinuousArgs`: the fragmented write in progress.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct uxrContinuousArgs {
    /// Its flush callback.
    pub flush_callback: OnBuffersFull,
    /// The callback's args.
    pub flush_callback_args: *mut c_void,
    /// Its stream.
    pub stream_id: uxrStreamId,
    /// Bytes announced.
    pub data_size: usize,
}

/// `uxrSession`: storage the C program declares; its named fields, then the Rust session in `_opaque`.
#[repr(C)]
pub struct uxrSession {
    /// `info`.
    pub info: uxrSessionInfo,
    /// `streams`.
    pub streams: uxrStreamStorage,
    /// `comm`.
    pub comm: *mut uxrCommunication,
    /// `request_list` (set while an `until_*_status` call runs).
    pub request_list: *const u16,
    /// `status_list` (likewise).
    pub status_list: *mut u8,
    /// `request_status_list_size` (likewise).
    pub request_status_list_size: usize,
    /// `on_status`.
    pub on_status: OnStatus,
    /// `on_status_args`.
    pub on_status_args: *mut c_void,
    /// `on_topic`.
    pub on_topic: OnTopic,
    /// `on_topic_args`.
    pub on_topic_args: *mut c_void,
    /// `on_time`.
    pub on_time: OnTime,
    /// `on_time_args`.
    pub on_time_args: *mut c_void,
    /// `time_offset`: local minus agent clock, nanoseconds.
    pub time_offset: i64,
    /// `synchronized`.
    pub synchronized: bool,
    /// `on_request`.
    pub on_request: OnRequest,
    /// `on_request_args`.
    pub on_request_args: *mut c_void,
    /// `on_reply`.
    pub on_reply: OnReply,
    /// `on_reply_args`.
    pub on_reply_args: *mut c_void,
    /// `on_data_flag`.
    pub on_data_flag: bool,
    /// `on_pong_flag`.
    pub on_pong_flag: u8,
    /// `continuous_args`.
    pub continuous_args: uxrContinuousArgs,
    /// The session's lock (multithread profile).
    #[cfg(uxr_multithread)]
    pub mutex: crate::lock::uxrMutex,
    /// The Rust session (a `Slot`, see the module above).
    pub _opaque: [u64; crate::layout::SESSION_WORDS],
}
