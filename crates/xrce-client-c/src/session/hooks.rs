//! The C callbacks of a session (`uxr_set_*_callback`), called from the Rust session's [`Callbacks`].

use core::ffi::c_void;
use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use xrce_client::{Callbacks, ObjectId, Outputs, StreamId, TimeSample};

use super::public::{PONG_IN_SESSION, PONG_NO_SESSION};
use super::{slot_at, uxrSession, Slot};
use crate::abi::{uxrObjectId, uxrStreamId, INPUT_STREAM};
use crate::types::SampleIdentity;
use crate::ucdr::buffer::{ucdrBuffer, LITTLE};

/// `uxrOnStatusFunc`.
pub type OnStatus = Option<unsafe extern "C" fn(*mut uxrSession, uxrObjectId, u16, u8, *mut c_void)>;
/// `uxrOnTopicFunc`.
pub type OnTopic =
    Option<unsafe extern "C" fn(*mut uxrSession, uxrObjectId, u16, uxrStreamId, *mut ucdrBuffer, u16, *mut c_void)>;
/// `uxrOnTimeFunc`.
pub type OnTime = Option<unsafe extern "C" fn(*mut uxrSession, i64, i64, i64, i64, *mut c_void)>;
/// `uxrOnRequestFunc`.
pub type OnRequest = Option<
    unsafe extern "C" fn(*mut uxrSession, uxrObjectId, u16, *mut SampleIdentity, *mut ucdrBuffer, u16, *mut c_void),
>;
/// `uxrOnReplyFunc`.
pub type OnReply =
    Option<unsafe extern "C" fn(*mut uxrSession, uxrObjectId, u16, u16, *mut ucdrBuffer, u16, *mut c_void)>;

/// The callbacks of one session: the C functions are the session's own fields (`on_status`, ...), read
/// when called, so a program may set them with `uxr_set_*_callback` or directly.
#[derive(Debug)]
pub struct Hooks {
    /// The C structure, handed to every callback.
    pub session: *mut uxrSession,
}

impl Hooks {
    /// Callbacks reading `session`'s fields.
    pub fn new(session: *mut uxrSession) -> Self {
        Self { session }
    }

    /// The session's slot: its address computed from `session`, not kept beside it (firmware size).
    fn slot(&self) -> *mut Slot {
        slot_at(self.session)
    }

    /// Calls `call` with `out` lent to any `uxr_buffer_*` the C callback makes on this session.
    fn lending(&mut self, out: &mut Outputs<'_, '_>, call: impl FnOnce(*mut uxrSession)) {
        // SAFETY: the callbacks run inside the initialised session's own slot; `in_callback` is only reached
        // through shared references.
        let cell = unsafe { &*addr_of!((*self.slot()).in_callback) };
        let previous = cell.replace(core::ptr::from_mut(out).cast());
        call(self.session);
        cell.set(previous);
    }

    /// Reads one of the session's named fields.
    fn get<T: Copy>(&self, field: impl FnOnce(*mut uxrSession) -> *mut T) -> T {
        // SAFETY: `session` is the initialised C structure the Rust session lives in; its named fields lie
        // outside `_opaque` (the Rust session's memory) and are plain data the program may change between calls.
        unsafe { field(self.session).read() }
    }

    /// Writes one of the session's named fields.
    fn set<T>(&self, field: impl FnOnce(*mut uxrSession) -> *mut T, value: T) {
        // SAFETY: as in `get`.
        unsafe { field(self.session).write(value) }
    }
}

/// A read-only CDR buffer over a received payload (little endian, as XRCE payloads travel).
/// Written into the caller's buffer, not returned and copied (firmware size).
#[inline(never)] // one copy for the three data callbacks (firmware size)
fn reader(data: &[u8], ub: &mut MaybeUninit<ucdrBuffer>) -> u16 {
    ub.write(ucdrBuffer::over(data.as_ptr().cast_mut(), data.len(), 0, 0, LITTLE));
    u16::try_from(data.len()).unwrap_or(u16::MAX)
}

impl Callbacks for Hooks {
    fn on_status(&mut self, out: &mut Outputs<'_, '_>, object_id: ObjectId, request_id: u16, status: u8) {
        let (Some(f), args) = (self.get(|s| field!(s, on_status)), self.get(|s| field!(s, on_status_args))) else {
            return;
        };
        let object = uxrObjectId::from_rust(object_id);
        // SAFETY: the C program's callback with its own args; the session pointer is the one it initialised.
        self.lending(out, |s| unsafe { f(s, object, request_id, status, args) });
    }

    fn on_topic(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        stream_id: StreamId,
        data: &[u8],
    ) {
        self.set(|s| field!(s, on_data_flag), true);
        let (Some(f), args) = (self.get(|s| field!(s, on_topic)), self.get(|s| field!(s, on_topic_args))) else {
            return;
        };
        let mut ub = MaybeUninit::uninit();
        let len = reader(data, &mut ub);
        let (object, stream) = (uxrObjectId::from_rust(object_id), uxrStreamId::from_rust(stream_id, INPUT_STREAM));
        // SAFETY: as in `on_status`; `ub`, written by `reader`, covers the payload, alive for the call, and is only
        // read through.
        self.lending(out, |s| unsafe { f(s, object, request_id, stream, ub.as_mut_ptr(), len, args) });
    }

    fn on_request(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        sample_id: &xrce_proto::SampleIdentity,
        data: &[u8],
    ) {
        let mut sample = SampleIdentity::from_rust(sample_id);
        // SAFETY: as in `lending`.
        unsafe { &*addr_of!((*self.slot()).last_request) }.set(Some(sample));
        self.set(|s| field!(s, on_data_flag), true);
        let (Some(f), args) = (self.get(|s| field!(s, on_request)), self.get(|s| field!(s, on_request_args))) else {
            return;
        };
        let mut ub = MaybeUninit::uninit();
        let len = reader(data, &mut ub);
        let object = uxrObjectId::from_rust(object_id);
        // SAFETY: as in `on_topic`; `sample` lives for the call.
        self.lending(out, |s| unsafe { f(s, object, request_id, &mut sample, ub.as_mut_ptr(), len, args) });
    }

    fn on_reply(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        reply_id: u16,
        data: &[u8],
    ) {
        self.set(|s| field!(s, on_data_flag), true);
        let (Some(f), args) = (self.get(|s| field!(s, on_reply)), self.get(|s| field!(s, on_reply_args))) else {
            return;
        };
        let mut ub = MaybeUninit::uninit();
        let len = reader(data, &mut ub);
        let object = uxrObjectId::from_rust(object_id);
        // SAFETY: as in `on_topic`.
        self.lending(out, |s| unsafe { f(s, object, request_id, reply_id, ub.as_mut_ptr(), len, args) });
    }

    fn on_time(&mut self, t: &TimeSample) -> bool {
        let (f, args) = (self.get(|s| field!(s, on_time)), self.get(|s| field!(s, on_time_args)));
        match f {
            // eProsima's order: after the local time, the agent's receive time, then its transmit time. The
            // callback owns `time_offset` (PX4 writes its own filtered estimate there).
            // SAFETY: as in `on_status` (nothing to lend: a time callback has no outputs).
            Some(f) => unsafe { f(self.session, t.current, t.received, t.transmit, t.originate, args) },
            None => self.set(|s| field!(s, time_offset), t.offset()),
        }
        self.set(|s| field!(s, synchronized), true);
        // The C session keeps the offset in its own field (uxr_epoch_nanos reads it): the Rust core's stays 0.
        true
    }

    fn on_pong(&mut self, in_session: bool) {
        self.set(|s| field!(s, on_pong_flag), if in_session { PONG_IN_SESSION } else { PONG_NO_SESSION });
    }
}

macro_rules! setter {
    ($(#[$m:meta])* $name:ident, $func:ident, $args:ident, $ty:ty) => {
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`; the callback and `args` stay valid while the session may call them.
        #[no_mangle]
        pub unsafe extern "C" fn $name(session: *mut uxrSession, func: $ty, args: *mut c_void) {
            if session.is_null() {
                return;
            }
            // SAFETY: non-null and a session (contract); named fields only, outside the Rust session's memory.
            unsafe {
                addr_of_mut!((*session).$func).write(func);
                addr_of_mut!((*session).$args).write(args);
            }
        }
    };
}

setter!(
    /// `uxr_set_status_callback`.
    uxr_set_status_callback, on_status, on_status_args, OnStatus
);
setter!(
    /// `uxr_set_topic_callback`.
    uxr_set_topic_callback, on_topic, on_topic_args, OnTopic
);
setter!(
    /// `uxr_set_time_callback`: the callback takes over `time_offset`, as in eProsima's client.
    uxr_set_time_callback, on_time, on_time_args, OnTime
);
setter!(
    /// `uxr_set_request_callback`.
    uxr_set_request_callback, on_request, on_request_args, OnRequest
);
setter!(
    /// `uxr_set_reply_callback`.
    uxr_set_reply_callback, on_reply, on_reply_args, OnReply
);
