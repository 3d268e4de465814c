//! Raw declarations of the shim's C ABI (`shim/xfast.cpp`); the structs mirror the C ones field by field.

use std::os::raw::{c_char, c_int, c_void};

/// A GUID as on the wire: 12-byte prefix, 4-byte entity id.
#[repr(C)]
#[derive(Clone, Copy, Default, Debug, PartialEq, Eq, Hash)]
pub struct Guid {
    /// The 16 bytes.
    pub v: [u8; 16],
}

/// Writer GUID and sequence number; `sn < 0` means unknown.
#[repr(C)]
#[derive(Clone, Copy, Default, Debug, PartialEq, Eq, Hash)]
pub struct SampleIdentity {
    /// Writer GUID.
    pub writer: Guid,
    /// Sequence number (negative: unknown).
    pub sn: i64,
}

#[repr(C)]
#[derive(Clone, Copy, Default, Debug)]
pub(crate) struct Qos {
    pub reliable: u8,
    pub transient_local: u8,
    pub keep_all: u8,
    pub _pad: u8,
    pub depth: i32,
    pub max_samples: i32,
    pub max_instances: i32,
    pub max_samples_per_instance: i32,
    pub max_blocking_ms: u32,
    pub heartbeat_ms: u32,
    pub acknack_delay_ms: u32,
}

#[repr(C)]
pub(crate) struct ParticipantCfg {
    pub domain: u32,
    pub name: *const c_char,
    pub whitelist: *const *const c_char,
    pub n_whitelist: usize,
    pub announcements: u32,
    pub announcement_period_ms: u32,
    pub shared_memory: u8,
    pub range: u8,
    pub _pad: [u8; 2],
    pub peers: *const *const c_char,
    pub n_peers: usize,
}

#[repr(C)]
pub(crate) struct TakeInfo {
    pub sample_identity: SampleIdentity,
    pub related_sample_identity: SampleIdentity,
    pub body: *const u8,
    pub len: usize,
    pub encapsulation: u16,
    pub valid_data: u8,
    pub _pad: u8,
}

pub(crate) enum XfParticipant {}
pub(crate) enum XfWriter {}
pub(crate) enum XfReader {}
pub(crate) enum XfTopic {}
pub(crate) type Cb = extern "C" fn(*mut c_void);

extern "C" {
    /// 1 with Fast DDS, 0 in the stub built without it (build.rs).
    pub(crate) fn xf_available() -> c_int;
    pub(crate) fn xf_load_profiles(file: *const c_char) -> c_int;
    pub(crate) fn xf_participant_new(cfg: *const ParticipantCfg) -> *mut XfParticipant;
    pub(crate) fn xf_participant_delete(p: *mut XfParticipant);
    pub(crate) fn xf_participant_guid(p: *const XfParticipant, out: *mut Guid);
    pub(crate) fn xf_register_type(p: *mut XfParticipant, type_name: *const c_char, keyed: u8) -> c_int;
    pub(crate) fn xf_topic_new(p: *mut XfParticipant, name: *const c_char, type_name: *const c_char) -> *mut XfTopic;
    pub(crate) fn xf_topic_delete(p: *mut XfParticipant, t: *mut XfTopic);
    pub(crate) fn xf_writer_new(
        p: *mut XfParticipant,
        t: *mut XfTopic,
        q: *const Qos,
        parts: *const *const c_char,
        n: usize,
    ) -> *mut XfWriter;
    pub(crate) fn xf_writer_delete(p: *mut XfParticipant, w: *mut XfWriter);
    pub(crate) fn xf_writer_guid(w: *const XfWriter, out: *mut Guid);
    pub(crate) fn xf_writer_matched(w: *mut XfWriter) -> i32;
    pub(crate) fn xf_writer_unmatched_known(w: *mut XfWriter, oracle: *mut XfParticipant) -> i32;
    pub(crate) fn xf_writer_unmatched_in_discovery(w: *mut XfWriter, oracle: *mut XfParticipant, settle_ms: u32)
        -> i32;
    pub(crate) fn xf_writer_matched_prefix(w: *mut XfWriter, prefix: *const u8) -> i32;
    pub(crate) fn xf_participant_in_discovery(p: *mut XfParticipant, oracle: *mut XfParticipant, settle_ms: u32)
        -> i32;
    pub(crate) fn xf_participant_undiscovered(p: *mut XfParticipant, oracle: *mut XfParticipant) -> i32;
    pub(crate) fn xf_participant_known_readers(p: *mut XfParticipant, topic: *const c_char) -> i32;
    pub(crate) fn xf_participant_reannounce_unheard(p: *mut XfParticipant) -> i32;
    pub(crate) fn xf_write(
        w: *mut XfWriter,
        body: *const u8,
        len: usize,
        related: *const SampleIdentity,
        written: *mut SampleIdentity,
    ) -> c_int;
    pub(crate) fn xf_writer_wait_acked(w: *mut XfWriter, ms: u32) -> c_int;
    pub(crate) fn xf_reader_new(
        p: *mut XfParticipant,
        t: *mut XfTopic,
        q: *const Qos,
        parts: *const *const c_char,
        n: usize,
        cb: Option<Cb>,
        ctx: *mut c_void,
    ) -> *mut XfReader;
    pub(crate) fn xf_reader_delete(p: *mut XfParticipant, r: *mut XfReader);
    pub(crate) fn xf_reader_guid(r: *const XfReader, out: *mut Guid);
    pub(crate) fn xf_reader_matched(r: *mut XfReader) -> i32;
    pub(crate) fn xf_take(r: *mut XfReader, info: *mut TakeInfo) -> c_int;
}
