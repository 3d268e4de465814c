//! The C callbacks of a session (`uxr_set_*_callback`), called from the Rust session's [`Callbacks`].

use core::cell::Cell;
use core::ffi::c_void;

use xrce_client::{Callbacks, ObjectId, Outputs, StreamId, TimeSample};

use super::{uxrSession, with_session, CallbackOutputs};
use crate::abi::{uxrObjectId, uxrStreamId, SampleIdentity, INPUT_STREAM};
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

/// A C callback and its user pointer.
#[derive(Debug, Clone, Copy)]
pub struct Hook<F> {
    /// The function, if set.
    pub func: F,
    /// Its `args`.
    pub args: *mut c_void,
}

impl<F: Default> Default for Hook<F> {
    fn default() -> Self {
        Self { func: F::default(), args: core::ptr::null_mut() }
    }
}

/// The callbacks of one session.
#[derive(Debug)]
pub struct Hooks {
    /// The C structure, handed to every callback.
    pub session: *mut uxrSession,
    in_callback: *const CallbackOutputs,
    last_request: *const Cell<Option<SampleIdentity>>,
    /// `uxr_set_status_callback`.
    pub status: Hook<OnStatus>,
    /// `uxr_set_topic_callback`.
    pub topic: Hook<OnTopic>,
    /// `uxr_set_time_callback`.
    pub time: Hook<OnTime>,
    /// `uxr_set_request_callback`.
    pub request: Hook<OnRequest>,
    /// `uxr_set_reply_callback`.
    pub reply: Hook<OnReply>,
}

impl Hooks {
    /// No callback set yet.
    pub fn new(
        session: *mut uxrSession,
        in_callback: *const CallbackOutputs,
        last_request: *const Cell<Option<SampleIdentity>>,
    ) -> Self {
        Self {
            session,
            in_callback,
            last_request,
            status: Hook::default(),
            topic: Hook::default(),
            time: Hook::default(),
            request: Hook::default(),
            reply: Hook::default(),
        }
    }

    /// Calls `call` with `out` lent to any `uxr_buffer_*` the C callback makes on this session.
    fn lending(&mut self, out: &mut Outputs<'_, '_>, call: impl FnOnce(*mut uxrSession)) {
        // SAFETY: `in_callback` points into the session's own storage, alive while the session is.
        let cell = unsafe { &*self.in_callback };
        let previous = cell.replace(core::ptr::from_mut(out).cast());
        call(self.session);
        cell.set(previous);
    }
}

/// A read-only CDR buffer over a received payload (little endian, as XRCE payloads travel).
fn reader(data: &[u8]) -> (ucdrBuffer, u16) {
    let ub = ucdrBuffer::over(data.as_ptr().cast_mut(), data.len(), 0, 0, LITTLE);
    (ub, u16::try_from(data.len()).unwrap_or(u16::MAX))
}

impl Callbacks for Hooks {
    fn on_status(&mut self, out: &mut Outputs<'_, '_>, object_id: ObjectId, request_id: u16, status: u8) {
        let Hook { func: Some(f), args } = self.status else { return };
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
        let Hook { func: Some(f), args } = self.topic else { return };
        let (mut ub, len) = reader(data);
        let (object, stream) = (uxrObjectId::from_rust(object_id), uxrStreamId::from_rust(stream_id, INPUT_STREAM));
        // SAFETY: as in `on_status`; `ub` covers the payload, alive for the call, and is only read through.
        self.lending(out, |s| unsafe { f(s, object, request_id, stream, &mut ub, len, args) });
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
        // SAFETY: `last_request` points into the session's own storage, alive while the session is.
        unsafe { &*self.last_request }.set(Some(sample));
        let Hook { func: Some(f), args } = self.request else { return };
        let (mut ub, len) = reader(data);
        let object = uxrObjectId::from_rust(object_id);
        // SAFETY: as in `on_topic`; `sample` lives for the call.
        self.lending(out, |s| unsafe { f(s, object, request_id, &mut sample, &mut ub, len, args) });
    }

    fn on_reply(
        &mut self,
        out: &mut Outputs<'_, '_>,
        object_id: ObjectId,
        request_id: u16,
        reply_id: u16,
        data: &[u8],
    ) {
        let Hook { func: Some(f), args } = self.reply else { return };
        let (mut ub, len) = reader(data);
        let object = uxrObjectId::from_rust(object_id);
        // SAFETY: as in `on_topic`.
        self.lending(out, |s| unsafe { f(s, object, request_id, reply_id, &mut ub, len, args) });
    }

    fn on_time(&mut self, t: &TimeSample) -> bool {
        let Hook { func: Some(f), args } = self.time else { return false };
        // SAFETY: as in `on_status` (nothing to lend: a time callback has no outputs).
        unsafe { f(self.session, t.current, t.transmit, t.received, t.originate, args) };
        true
    }
}

macro_rules! setter {
    ($(#[$m:meta])* $name:ident, $field:ident, $ty:ty) => {
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`; the callback and `args` stay valid while the session may call them.
        #[no_mangle]
        pub unsafe extern "C" fn $name(session: *mut uxrSession, func: $ty, args: *mut c_void) {
            // SAFETY: contract.
            unsafe { with_session(session, (), |s| s.callbacks().$field = Hook { func, args }) }
        }
    };
}

setter!(
    /// `uxr_set_status_callback`.
    uxr_set_status_callback, status, OnStatus
);
setter!(
    /// `uxr_set_topic_callback`.
    uxr_set_topic_callback, topic, OnTopic
);
setter!(
    /// `uxr_set_time_callback`: the callback takes over the clock offset computation, as in eProsima's client.
    uxr_set_time_callback, time, OnTime
);
setter!(
    /// `uxr_set_request_callback`.
    uxr_set_request_callback, request, OnRequest
);
setter!(
    /// `uxr_set_reply_callback`.
    uxr_set_reply_callback, reply, OnReply
);
