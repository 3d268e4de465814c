//! Fast DDS 2.x or 3.x (where ROS 2 users have it: build.rs) for the xrce-rs agent: a small C++ shim
//! (`shim/xfast.cpp`, the version differences in `shim/compat.hpp`) and
//! safe wrappers for untyped pub/sub. Topic and type names are runtime strings and samples are opaque CDR
//! bodies (the shim adds and strips the 4-byte encapsulation header), which is what an XRCE agent forwards.
//!
//! Participants start from the user's default XML profile and use shared memory beside UDPv4 when asked
//! ([`ParticipantConfig::shared_memory`]): only peers of the same Fast DDS version may share `/dev/shm`
//! (2.9 aborts on 2.14's segments). Data sharing stays off (the types are opaque and unbounded).
//!
//! Lifetimes: every topic, writer and reader holds an `Arc` on its participant, so the participant is deleted
//! last. A reader's data callback is installed at creation and removed (waiting for a call in progress) before
//! the reader is deleted, so the callback's context outlives every call.

mod ffi;

use std::ffi::{c_void, CString};
use std::os::raw::c_char;
use std::ptr;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

pub use ffi::{Guid, SampleIdentity};

/// Why a Fast DDS call failed (the shim reports no more detail than this).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Error {
    /// A name contained a NUL byte.
    Nul,
    /// Fast DDS refused to create the entity.
    Create(&'static str),
    /// A write was refused: the history stayed full for `max_blocking_time`.
    WouldBlock,
    /// Another failure of the named operation (shim return code).
    Op(&'static str, i32),
    /// This build has no Fast DDS (its headers were missing when it was compiled).
    Unavailable,
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Nul => f.write_str("name contains a NUL byte"),
            Error::Create(what) => write!(f, "Fast DDS cannot create the {what}"),
            Error::WouldBlock => f.write_str("writer history full"),
            Error::Op(what, rc) => write!(f, "Fast DDS {what} failed ({rc})"),
            Error::Unavailable => f.write_str(
                "this build has no Fast DDS engine: install libfastrtps-dev and g++, then rebuild with --features fastdds",
            ),
        }
    }
}

impl std::error::Error for Error {}

/// Endpoint QoS as Fast DDS takes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Qos {
    /// Reliable (else best effort).
    pub reliable: bool,
    /// TRANSIENT_LOCAL (else volatile).
    pub transient_local: bool,
    /// `None`: KEEP_ALL; `Some(depth)`: KEEP_LAST.
    pub keep_last: Option<u32>,
    /// max_samples, max_instances, max_samples_per_instance; 0 = unlimited.
    pub limits: (u32, u32, u32),
    /// How long a reliable write waits for room before [`Error::WouldBlock`].
    pub max_blocking_time: Duration,
    /// Reliable writers: HEARTBEAT period. Shorter than Fast DDS' 3 s so readers acknowledge, and the writer
    /// frees its history, often enough for a sustained stream.
    pub heartbeat_period: Duration,
    /// Reliable readers: delay of the first ACKNACK after matching (Fast DDS default 70 ms, which adds that
    /// much to first contact).
    pub initial_acknack_delay: Duration,
    /// Partitions (of the endpoint's own publisher or subscriber).
    pub partitions: Vec<String>,
}

impl Default for Qos {
    fn default() -> Self {
        Self {
            reliable: true,
            transient_local: false,
            keep_last: Some(1),
            limits: (0, 0, 0),
            max_blocking_time: Duration::from_millis(100),
            heartbeat_period: Duration::from_millis(100),
            initial_acknack_delay: Duration::from_millis(1),
            partitions: Vec::new(),
        }
    }
}

fn millis(d: Duration) -> u32 {
    u32::try_from(d.as_millis()).unwrap_or(u32::MAX)
}

impl Qos {
    fn raw(&self) -> ffi::Qos {
        let c = |v: u32| i32::try_from(v).unwrap_or(i32::MAX);
        ffi::Qos {
            reliable: u8::from(self.reliable),
            transient_local: u8::from(self.transient_local),
            keep_all: u8::from(self.keep_last.is_none()),
            _pad: 0,
            depth: c(self.keep_last.unwrap_or(1).max(1)),
            max_samples: c(self.limits.0),
            max_instances: c(self.limits.1),
            max_samples_per_instance: c(self.limits.2),
            max_blocking_ms: millis(self.max_blocking_time),
            heartbeat_ms: millis(self.heartbeat_period).max(1),
            acknack_delay_ms: millis(self.initial_acknack_delay),
        }
    }
}

/// How a participant is created.
#[derive(Clone, Debug, Default)]
pub struct ParticipantConfig {
    /// DDS domain id.
    pub domain: u32,
    /// Participant name (announced in discovery).
    pub name: String,
    /// Interface addresses the UDPv4 transport may use; empty: all.
    pub whitelist: Vec<String>,
    /// Initial SPDP announcements: how many, and how far apart.
    pub announcements: (u32, Duration),
    /// Shared memory beside UDPv4 (Fast DDS' built-in transports, as a ROS 2 node of the same distribution
    /// runs); `false`: UDPv4 only. Ignored when the user's profile sets the transports.
    pub shared_memory: bool,
    /// How far automatic discovery reaches (`ROS_AUTOMATIC_DISCOVERY_RANGE`, as rmw_fastrtps applies it).
    pub range: DiscoveryRange,
    /// Initial peers (IPv4 addresses) added to the profile's: `ROS_STATIC_PEERS` resolved, and for the
    /// LOCALHOST range `127.0.0.1`.
    pub peers: Vec<String>,
}

/// How far a participant's automatic discovery reaches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// Fast DDS' own: multicast on every interface (SUBNET and SYSTEM_DEFAULT).
    #[default]
    Default,
    /// This host only: no multicast discovery, unicast to the peers (and `127.0.0.1`).
    Localhost,
    /// No automatic discovery at all.
    Off,
}

fn cstr(s: &str) -> Result<CString, Error> {
    CString::new(s).map_err(|_| Error::Nul)
}

/// Owned C strings and the pointer array Fast DDS reads them through.
struct CStrings {
    _owned: Vec<CString>,
    ptrs: Vec<*const c_char>,
}

fn cstrs<S: AsRef<str>>(v: &[S]) -> Result<CStrings, Error> {
    let owned = v.iter().map(|s| cstr(s.as_ref())).collect::<Result<Vec<_>, _>>()?;
    let ptrs = owned.iter().map(|c| c.as_ptr()).collect();
    Ok(CStrings { _owned: owned, ptrs })
}

struct PInner(*mut ffi::XfParticipant);

// SAFETY: a Fast DDS DomainParticipant is internally synchronized and the shim's wrapper holds only its
// pointer, so it may be used and deleted from any thread.
unsafe impl Send for PInner {}
// SAFETY: see Send; every shim participant function may run concurrently (Fast DDS locks internally).
unsafe impl Sync for PInner {}

impl Drop for PInner {
    fn drop(&mut self) {
        // SAFETY: self.0 came from xf_participant_new and is non-null; topics, writers and readers hold an Arc
        // on this PInner, so they are all gone and the participant is deleted exactly once.
        unsafe { ffi::xf_participant_delete(self.0) }
    }
}

/// A domain participant. Clones share it.
#[derive(Clone)]
pub struct Participant(Arc<PInner>);

impl std::fmt::Debug for Participant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Participant").field(&self.guid()).finish()
    }
}

/// A topic of a participant.
pub struct Topic {
    p: Arc<PInner>,
    t: *mut ffi::XfTopic,
}

// SAFETY: the topic pointer is only handed back to the participant's create_datawriter/create_datareader and
// delete_topic, which Fast DDS synchronizes; the participant outlives it (Arc).
unsafe impl Send for Topic {}
// SAFETY: as for Send; nothing mutates through &Topic.
unsafe impl Sync for Topic {}

impl Drop for Topic {
    fn drop(&mut self) {
        // SAFETY: t belongs to participant p (alive via the Arc). Fast DDS refuses (and keeps the topic) while
        // endpoints use it; the caller drops topics after their endpoints, and leftovers go with the participant.
        unsafe { ffi::xf_topic_delete(self.p.0, self.t) }
    }
}

/// The Fast DDS this build links and where it was found (`Fast DDS 2.14.5 (/opt/ros/jazzy)`), or why none.
pub const BUILT_WITH: &str = env!("XRCE_FASTDDS_BUILT_WITH");

/// The environment variable naming the user's profiles file that this build's Fast DDS reads:
/// `FASTRTPS_DEFAULT_PROFILES_FILE` (2.x) or `FASTDDS_DEFAULT_PROFILES_FILE` (3.x); empty without Fast DDS.
pub const PROFILES_ENV: &str = env!("XRCE_FASTDDS_PROFILES_ENV");

/// Loads the user's Fast DDS XML profiles, as a ROS 2 node does before creating its participant: `file`
/// (the one [`PROFILES_ENV`] names; `None` when unset) and `DEFAULT_FASTRTPS_PROFILES.xml` (3.x:
/// `DEFAULT_FASTDDS_PROFILES.xml`) in the working directory. Their default participant and endpoint profiles
/// are the base of what [`Participant::new`] creates. Fails when `file` does not parse (Fast DDS logs why);
/// without Fast DDS, does nothing.
pub fn load_profiles(file: Option<&std::path::Path>) -> Result<(), Error> {
    // Fast DDS loads the variable's file by its absolute path; the same path marks it as loaded.
    let absolute = file.map(|f| std::fs::canonicalize(f).unwrap_or_else(|_| f.to_path_buf()));
    let c = absolute.map(|f| cstr(&f.to_string_lossy())).transpose()?;
    // SAFETY: `c` is a NUL-terminated string alive for the call (or null); Fast DDS' factory is a
    // process-wide singleton that synchronizes itself.
    match unsafe { ffi::xf_load_profiles(c.as_ref().map_or(ptr::null(), |c| c.as_ptr())) } {
        0 => Ok(()),
        rc => Err(Error::Op("load_profiles", rc)),
    }
}

/// Whether participants use shared memory unless told otherwise: true when this build's Fast DDS came from a
/// ROS 2 installation (the nodes beside the agent run the same version), false for `/usr` (Debian's 2.9,
/// which ROS 2 nodes do not run) and without Fast DDS.
pub const SHARED_MEMORY_BY_DEFAULT: bool = const_str_is_true(env!("XRCE_FASTDDS_SHARED_MEMORY_DEFAULT"));

const fn const_str_is_true(s: &str) -> bool {
    matches!(s.as_bytes(), b"true")
}

/// Whether this build links Fast DDS (false when it was compiled without Fast DDS' headers).
pub fn available() -> bool {
    // SAFETY: takes nothing, returns a constant.
    unsafe { ffi::xf_available() != 0 }
}

impl Participant {
    /// Creates a participant from the user's default profile (see [`load_profiles`]) and `cfg`.
    pub fn new(cfg: &ParticipantConfig) -> Result<Self, Error> {
        if !available() {
            return Err(Error::Unavailable);
        }
        let name = cstr(&cfg.name)?;
        let wl = cstrs(&cfg.whitelist)?;
        let peers = cstrs(&cfg.peers)?;
        let raw = ffi::ParticipantCfg {
            domain: cfg.domain,
            name: name.as_ptr(),
            whitelist: wl.ptrs.as_ptr(),
            n_whitelist: wl.ptrs.len(),
            announcements: cfg.announcements.0,
            announcement_period_ms: millis(cfg.announcements.1).max(1),
            shared_memory: u8::from(cfg.shared_memory),
            range: match cfg.range {
                DiscoveryRange::Default => 0,
                DiscoveryRange::Localhost => 1,
                DiscoveryRange::Off => 2,
            },
            _pad: [0; 2],
            peers: peers.ptrs.as_ptr(),
            n_peers: peers.ptrs.len(),
        };
        // SAFETY: raw and every string it points to are alive for the call; the shim copies them.
        let p = unsafe { ffi::xf_participant_new(&raw) };
        if p.is_null() {
            return Err(Error::Create("participant"));
        }
        Ok(Participant(Arc::new(PInner(p))))
    }

    /// Remote participants whose discovery with this one is still under way (0 on error): those it has
    /// discovered but has no endpoint of yet, or (with a non-zero `settle`) whose latest endpoint reached it or
    /// `oracle` less than `settle` ago, and those `oracle` (another participant of the process, which has run
    /// longer; or this one) knows and this one has not discovered yet.
    pub fn in_discovery(&self, oracle: &Participant, settle: Duration) -> usize {
        // SAFETY: both participants are alive for the call (held by `self` and `oracle`); the shim locks
        // their discovery tables one after the other.
        let n = unsafe { ffi::xf_participant_in_discovery(self.0 .0, oracle.0 .0, millis(settle)) };
        usize::try_from(n).unwrap_or(0)
    }

    /// Participants `oracle` (another participant of the process, which has run longer) has discovered, and
    /// `oracle` itself, that this one has not discovered (0 on error, and when `oracle` is this one). Right
    /// after creation, one that stays undiscovered answered this participant's first announcement before
    /// Fast DDS listened for the answer (see `Participant::new`'s callers in xrce-dds).
    pub fn undiscovered(&self, oracle: &Participant) -> usize {
        // SAFETY: both participants are alive for the call (held by `self` and `oracle`); the shim locks
        // their discovery tables one after the other.
        usize::try_from(unsafe { ffi::xf_participant_undiscovered(self.0 .0, oracle.0 .0) }).unwrap_or(0)
    }

    /// Remote readers on `topic` this participant has discovered and not seen leave (0 on error, and for a
    /// topic name with a NUL byte).
    pub fn known_readers(&self, topic: &str) -> usize {
        let Ok(topic) = CString::new(topic) else { return 0 };
        // SAFETY: live participant (held by `self`); `topic` is a NUL-terminated string that outlives the call;
        // the shim reads the participant's discovery table under its lock.
        usize::try_from(unsafe { ffi::xf_participant_known_readers(self.0 .0, topic.as_ptr()) }).unwrap_or(0)
    }

    /// Asks every other participant of this process in its domain that this one has not discovered to announce
    /// itself again (their answers to this one's first announcement may have been dropped); how many were asked.
    /// They announce by changing their USER_DATA to `xrce-rs-announce=N;` (ROS 2 reads only `enclave=`).
    pub fn reannounce_unheard(&self) -> usize {
        // SAFETY: live participant; the shim walks its registry of live participants under a lock that their
        // deletion also takes.
        usize::try_from(unsafe { ffi::xf_participant_reannounce_unheard(self.0 .0) }).unwrap_or(0)
    }

    /// The participant's GUID.
    pub fn guid(&self) -> Guid {
        let mut g = Guid::default();
        // SAFETY: live participant; g is a valid out pointer.
        unsafe { ffi::xf_participant_guid(self.0 .0, &mut g) };
        g
    }

    /// Creates topic `name` of the opaque type `type_name` (registered on first use).
    pub fn topic(&self, name: &str, type_name: &str, keyed: bool) -> Result<Topic, Error> {
        let n = cstr(name)?;
        let tn = cstr(type_name)?;
        // SAFETY: live participant; tn is a valid C string for the call (Fast DDS copies it).
        if unsafe { ffi::xf_register_type(self.0 .0, tn.as_ptr(), u8::from(keyed)) } != 0 {
            return Err(Error::Create("type"));
        }
        // SAFETY: live participant; both strings valid for the call.
        let t = unsafe { ffi::xf_topic_new(self.0 .0, n.as_ptr(), tn.as_ptr()) };
        if t.is_null() {
            return Err(Error::Create("topic"));
        }
        Ok(Topic { p: Arc::clone(&self.0), t })
    }

    /// Creates a datawriter on `topic` (which must be this participant's).
    pub fn writer(&self, topic: &Topic, qos: &Qos) -> Result<Writer, Error> {
        if !Arc::ptr_eq(&self.0, &topic.p) {
            return Err(Error::Create("writer (topic of another participant)"));
        }
        let parts = cstrs(&qos.partitions)?;
        let q = qos.raw();
        // SAFETY: live participant and a topic of it; q and parts valid for the call.
        let w = unsafe { ffi::xf_writer_new(self.0 .0, topic.t, &q, parts.ptrs.as_ptr(), parts.ptrs.len()) };
        if w.is_null() {
            return Err(Error::Create("writer"));
        }
        Ok(Writer { p: Arc::clone(&self.0), w })
    }

    /// Creates a datareader on `topic`; `on_data` runs on a Fast DDS thread whenever data arrives. It must not
    /// block for long and must not drop the reader.
    pub fn reader(
        &self,
        topic: &Topic,
        qos: &Qos,
        on_data: impl Fn() + Send + Sync + 'static,
    ) -> Result<Reader, Error> {
        if !Arc::ptr_eq(&self.0, &topic.p) {
            return Err(Error::Create("reader (topic of another participant)"));
        }
        let parts = cstrs(&qos.partitions)?;
        let q = qos.raw();
        let cb: Box<Callback> = Box::new(Box::new(on_data));
        let ctx = ptr::from_ref::<Callback>(&cb).cast_mut().cast::<c_void>();
        // SAFETY: live participant and a topic of it; q and parts valid for the call; ctx points into the heap
        // box stored in the returned Reader, which xf_reader_delete stops using before the box is freed.
        let r = unsafe {
            ffi::xf_reader_new(self.0 .0, topic.t, &q, parts.ptrs.as_ptr(), parts.ptrs.len(), Some(trampoline), ctx)
        };
        if r.is_null() {
            return Err(Error::Create("reader"));
        }
        let inner = Arc::new(RInner { p: Arc::clone(&self.0), r: Mutex::new(r) });
        Ok(Reader { inner, _cb: cb })
    }
}

/// A datawriter of opaque CDR bodies. Writes may run concurrently from several threads.
pub struct Writer {
    p: Arc<PInner>,
    w: *mut ffi::XfWriter,
}

// SAFETY: xf_write keeps its sample on its own stack frame and Fast DDS' DataWriter is internally
// synchronized, so the writer may be used from any thread and from several at once.
unsafe impl Send for Writer {}
// SAFETY: see Send.
unsafe impl Sync for Writer {}

impl std::fmt::Debug for Writer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Writer").field(&self.guid()).finish()
    }
}

impl Writer {
    /// The writer's GUID.
    pub fn guid(&self) -> Guid {
        let mut g = Guid::default();
        // SAFETY: live writer; valid out pointer.
        unsafe { ffi::xf_writer_guid(self.w, &mut g) };
        g
    }

    /// Matched readers (negative on error).
    pub fn matched(&self) -> i32 {
        // SAFETY: live writer; the status call is synchronized by Fast DDS.
        unsafe { ffi::xf_writer_matched(self.w) }
    }

    /// Readers `oracle` has discovered on this writer's topic and type, with a QoS the writer can serve,
    /// that the writer has not matched yet (0 on error). `oracle` may be another participant of the process:
    /// one that has run longer has discovered more.
    pub fn unmatched_known(&self, oracle: &Participant) -> usize {
        // SAFETY: live writer; `oracle` keeps its participant alive for the call; the shim locks the
        // participant's discovery table and the writer's matched set.
        let n = unsafe { ffi::xf_writer_unmatched_known(self.w, oracle.0 .0) };
        usize::try_from(n).unwrap_or(0)
    }

    /// Of the readers [`Writer::unmatched_known`] counts, those whose participant this writer's participant
    /// has not discovered, or has no endpoint of yet, or (with a non-zero `settle`) received an endpoint of
    /// less than `settle` ago (0 on error): discovery with them is under way, so the writer may still match
    /// them; a reader whose participant's endpoints did arrive will not.
    pub fn unmatched_in_discovery(&self, oracle: &Participant, settle: Duration) -> usize {
        // SAFETY: live writer, whose participant `self.p` keeps alive; `oracle` keeps its participant alive for
        // the call; the shim locks the matched set and the two discovery tables one after the other.
        let n = unsafe { ffi::xf_writer_unmatched_in_discovery(self.w, oracle.0 .0, millis(settle)) };
        usize::try_from(n).unwrap_or(0)
    }

    /// Whether the writer has matched a reader of the participant with GUID prefix `prefix` (false on error).
    pub fn matched_prefix(&self, prefix: &[u8; 12]) -> bool {
        // SAFETY: live writer; `prefix` is 12 readable bytes for the call; the shim locks the matched set.
        unsafe { ffi::xf_writer_matched_prefix(self.w, prefix.as_ptr()) == 1 }
    }

    /// Writes a CDR body (no encapsulation header; sent as CDR_LE); returns the sample's identity.
    pub fn write(&self, body: &[u8], related: Option<&SampleIdentity>) -> Result<SampleIdentity, Error> {
        let mut out = SampleIdentity::default();
        let rel = related.map_or(ptr::null(), ptr::from_ref);
        // SAFETY: live writer; body valid for len bytes during the call (serialized before it returns); rel
        // null or valid; out a valid out pointer.
        let rc = unsafe { ffi::xf_write(self.w, body.as_ptr(), body.len(), rel, &mut out) };
        match rc {
            0 => Ok(out),
            -1 => Err(Error::WouldBlock),
            e => Err(Error::Op("write", e)),
        }
    }

    /// Waits until matched reliable readers acknowledged everything; false on timeout.
    pub fn wait_for_acknowledgments(&self, max_wait: Duration) -> bool {
        // SAFETY: live writer.
        unsafe { ffi::xf_writer_wait_acked(self.w, millis(max_wait)) == 0 }
    }
}

impl Drop for Writer {
    fn drop(&mut self) {
        // SAFETY: w belongs to participant p (alive via the Arc) and is deleted exactly once.
        unsafe { ffi::xf_writer_delete(self.p.0, self.w) }
    }
}

/// A sample taken from a reader.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sample {
    /// CDR body without the encapsulation header.
    pub body: Vec<u8>,
    /// Representation identifier (`0x0001` CDR_LE).
    pub encapsulation: u16,
    /// False for dispose/unregister notifications (no body).
    pub valid: bool,
    /// Writer GUID and sequence number.
    pub identity: SampleIdentity,
    /// Related sample identity the writer attached (unknown GUID zero and `sn < 0` when none).
    pub related: SampleIdentity,
}

type Callback = Box<dyn Fn() + Send + Sync>;

extern "C" fn trampoline(ctx: *mut c_void) {
    // SAFETY: ctx is the address of the Box<Callback> owned by the Reader; the shim calls this only while the
    // reader's listener is installed, and Reader::drop removes it (waiting for a call in progress) first.
    let cb = unsafe { &*ctx.cast_const().cast::<Callback>() };
    // A panic must not unwind into C++.
    if std::panic::catch_unwind(std::panic::AssertUnwindSafe(cb)).is_err() {
        std::process::abort();
    }
}

struct RInner {
    p: Arc<PInner>,
    /// Null once the reader is deleted; the mutex also serializes takes (the shim's scratch sample).
    r: Mutex<*mut ffi::XfReader>,
}

// SAFETY: the reader pointer is only used under the mutex, and Fast DDS' DataReader may be used from any thread.
unsafe impl Send for RInner {}
// SAFETY: see Send.
unsafe impl Sync for RInner {}

/// A datareader of opaque CDR bodies.
pub struct Reader {
    inner: Arc<RInner>,
    _cb: Box<Callback>,
}

impl std::fmt::Debug for Reader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Reader").field(&self.guid()).finish()
    }
}

/// Takes samples from a reader from any thread; after the reader is dropped it only reports "no data".
#[derive(Clone)]
pub struct ReaderHandle(Arc<RInner>);

impl ReaderHandle {
    /// Takes the next sample, if any.
    pub fn take(&self) -> Result<Option<Sample>, Error> {
        let r = self.0.r.lock().unwrap_or_else(PoisonError::into_inner);
        if r.is_null() {
            return Ok(None);
        }
        let mut info = ffi::TakeInfo {
            sample_identity: SampleIdentity::default(),
            related_sample_identity: SampleIdentity::default(),
            body: ptr::null(),
            len: 0,
            encapsulation: 0,
            valid_data: 0,
            _pad: 0,
        };
        // SAFETY: live reader (non-null under the lock), takes serialized by the lock; info a valid out pointer.
        let rc = unsafe { ffi::xf_take(*r, &mut info) };
        match rc {
            0 => return Ok(None),
            1 => {}
            e => return Err(Error::Op("take", e)),
        }
        let body = if info.body.is_null() || info.len == 0 {
            Vec::new()
        } else {
            // SAFETY: the shim points body at its scratch sample of len bytes, unchanged until the next take,
            // which cannot start while we hold the lock.
            unsafe { std::slice::from_raw_parts(info.body, info.len) }.to_vec()
        };
        Ok(Some(Sample {
            body,
            encapsulation: info.encapsulation,
            valid: info.valid_data != 0,
            identity: info.sample_identity,
            related: info.related_sample_identity,
        }))
    }
}

impl Reader {
    /// The reader's GUID.
    pub fn guid(&self) -> Guid {
        let r = self.inner.r.lock().unwrap_or_else(PoisonError::into_inner);
        let mut g = Guid::default();
        if !r.is_null() {
            // SAFETY: live reader; valid out pointer.
            unsafe { ffi::xf_reader_guid(*r, &mut g) };
        }
        g
    }

    /// Matched writers (negative on error).
    pub fn matched(&self) -> i32 {
        let r = self.inner.r.lock().unwrap_or_else(PoisonError::into_inner);
        // SAFETY: live reader (checked non-null under the lock).
        if r.is_null() {
            -1
        } else {
            unsafe { ffi::xf_reader_matched(*r) }
        }
    }

    /// A handle taking from this reader from another thread.
    pub fn handle(&self) -> ReaderHandle {
        ReaderHandle(Arc::clone(&self.inner))
    }
}

impl Drop for Reader {
    fn drop(&mut self) {
        let mut r = self.inner.r.lock().unwrap_or_else(PoisonError::into_inner);
        let raw = std::mem::replace(&mut *r, ptr::null_mut());
        drop(r);
        // SAFETY: raw belongs to participant p (alive via the Arc), is deleted exactly once (the pointer was
        // swapped for null under the lock, so no take uses it afterwards), and xf_reader_delete removes the
        // callback, waiting for a call in progress, before self._cb is freed.
        unsafe { ffi::xf_reader_delete(self.inner.p.0, raw) }
    }
}

impl std::fmt::Display for Guid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, b) in self.v.iter().enumerate() {
            if i == 12 {
                f.write_str("|")?;
            }
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}
