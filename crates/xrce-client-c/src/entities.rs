//! `uxr_buffer_create_*` (XML, reference, binary) and `uxr_buffer_delete_entity`: request id, or
//! `UXR_INVALID_REQUEST_ID` (0) for a bad session, stream, string or a full stream.

use core::ffi::{c_char, CStr};

use xrce_client::ServiceNames;

use crate::abi::{uxrObjectId, uxrQoS_t, uxrStreamId};
use crate::session::{uxrSession, with_outputs};

/// A C string's bytes (without the NUL); `None` for null. XML and references go to the agent as they are, as in
/// eProsima's library: no UTF-8 check (which cost 552 B of firmware).
///
/// # Safety
/// `s` null or NUL-terminated, alive for `'s`.
pub unsafe fn text_bytes<'s>(s: *const c_char) -> Option<&'s [u8]> {
    if s.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated (contract).
    Some(unsafe { CStr::from_ptr(s) }.to_bytes())
}

/// A C string as UTF-8; `None` for null or invalid UTF-8.
///
/// # Safety
/// `s` null or NUL-terminated, alive for `'s`.
pub unsafe fn text<'s>(s: *const c_char) -> Option<&'s str> {
    if s.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated (contract).
    unsafe { CStr::from_ptr(s) }.to_str().ok()
}

/// What a CREATE by text hangs from: a domain (participants) or a parent object.
#[derive(Clone, Copy)]
enum Link {
    Domain(u16),
    Parent(uxrObjectId),
}

impl From<u16> for Link {
    fn from(d: u16) -> Self {
        Self::Domain(d)
    }
}

impl From<uxrObjectId> for Link {
    fn from(p: uxrObjectId) -> Self {
        Self::Parent(p)
    }
}

/// Every CREATE by XML or reference: the core's encoding differs only by the link and by XML against
/// reference, so one out-of-line function with one `with_outputs` instance serves the fourteen entry points
/// (firmware size).
///
/// # Safety
/// `session` null or a `uxrSession`; `text_arg` null or NUL-terminated.
#[inline(never)]
unsafe fn create_text(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    object_id: uxrObjectId,
    link: Link,
    text_arg: *const c_char,
    xml: bool,
    mode: u8,
) -> u16 {
    // SAFETY: contract.
    let Some(t) = (unsafe { text_bytes(text_arg) }) else { return 0 };
    let (stream, object) = (stream_id.rust(), object_id.rust());
    // SAFETY: contract.
    unsafe {
        with_outputs(session, 0, |mut o| {
            match (link, xml) {
                (Link::Domain(d), true) => o.buffer_create_participant_xml(stream, object, d, t, mode),
                (Link::Domain(d), false) => o.buffer_create_participant_ref(stream, object, d, t, mode),
                (Link::Parent(p), true) => o.buffer_create_topic_xml(stream, object, p.rust(), t, mode),
                (Link::Parent(p), false) => o.buffer_create_topic_ref(stream, object, p.rust(), t, mode),
            }
            .unwrap_or(0)
        })
    }
}

macro_rules! create_by_text {
    ($($(#[$m:meta])* $name:ident($parent:ident: $pty:ty, $xml:expr));* $(;)?) => {$(
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`; the string null or NUL-terminated.
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            session: *mut uxrSession,
            stream_id: uxrStreamId,
            object_id: uxrObjectId,
            $parent: $pty,
            text_arg: *const c_char,
            mode: u8,
        ) -> u16 {
            // SAFETY: contract.
            unsafe { create_text(session, stream_id, object_id, Link::from($parent), text_arg, $xml, mode) }
        }
    )*};
}

create_by_text! {
    /// `uxr_buffer_create_participant_xml`.
    uxr_buffer_create_participant_xml(domain_id: u16, true);
    /// `uxr_buffer_create_topic_xml`.
    uxr_buffer_create_topic_xml(participant_id: uxrObjectId, true);
    /// `uxr_buffer_create_publisher_xml`.
    uxr_buffer_create_publisher_xml(participant_id: uxrObjectId, true);
    /// `uxr_buffer_create_subscriber_xml`.
    uxr_buffer_create_subscriber_xml(participant_id: uxrObjectId, true);
    /// `uxr_buffer_create_datawriter_xml`.
    uxr_buffer_create_datawriter_xml(publisher_id: uxrObjectId, true);
    /// `uxr_buffer_create_datareader_xml`.
    uxr_buffer_create_datareader_xml(subscriber_id: uxrObjectId, true);
    /// `uxr_buffer_create_requester_xml`.
    uxr_buffer_create_requester_xml(participant_id: uxrObjectId, true);
    /// `uxr_buffer_create_replier_xml`.
    uxr_buffer_create_replier_xml(participant_id: uxrObjectId, true);
    /// `uxr_buffer_create_topic_ref`.
    uxr_buffer_create_topic_ref(participant_id: uxrObjectId, false);
    /// `uxr_buffer_create_datawriter_ref`.
    uxr_buffer_create_datawriter_ref(publisher_id: uxrObjectId, false);
    /// `uxr_buffer_create_datareader_ref`.
    uxr_buffer_create_datareader_ref(subscriber_id: uxrObjectId, false);
    /// `uxr_buffer_create_requester_ref`.
    uxr_buffer_create_requester_ref(participant_id: uxrObjectId, false);
    /// `uxr_buffer_create_replier_ref`.
    uxr_buffer_create_replier_ref(participant_id: uxrObjectId, false);
    /// `uxr_buffer_create_participant_ref` as eProsima's library declares it (with a domain).
    uxr_buffer_create_participant_ref(domain_id: u16, false);
}

/// `uxr_buffer_create_participant_ref` as the seed's text writes it (no domain argument: domain 0); client.h
/// picks it by argument count.
///
/// # Safety
/// As [`uxr_buffer_create_participant_ref`].
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_create_participant_ref_seed(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    object_id: uxrObjectId,
    reference: *const c_char,
    mode: u8,
) -> u16 {
    // SAFETY: contract.
    unsafe { uxr_buffer_create_participant_ref(session, stream_id, object_id, 0, reference, mode) }
}

/// `uxr_buffer_create_participant_bin`: a null name creates an unnamed participant.
///
/// # Safety
/// `session` null or a `uxrSession`; `name` null or NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_create_participant_bin(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    object_id: uxrObjectId,
    domain_id: u16,
    name: *const c_char,
    mode: u8,
) -> u16 {
    // SAFETY: contract.
    let name = unsafe { text(name) };
    // SAFETY: contract.
    unsafe {
        with_outputs(session, 0, |mut o| {
            o.buffer_create_participant_bin(stream_id.rust(), object_id.rust(), domain_id, name, mode).unwrap_or(0)
        })
    }
}

/// `uxr_buffer_create_topic_bin`.
///
/// # Safety
/// `session` null or a `uxrSession`; the names null or NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_create_topic_bin(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    object_id: uxrObjectId,
    participant_id: uxrObjectId,
    topic_name: *const c_char,
    type_name: *const c_char,
    mode: u8,
) -> u16 {
    // SAFETY: contract.
    let (Some(topic), Some(ty)) = (unsafe { (text(topic_name), text(type_name)) }) else { return 0 };
    // SAFETY: contract.
    unsafe {
        with_outputs(session, 0, |mut o| {
            o.buffer_create_topic_bin(stream_id.rust(), object_id.rust(), participant_id.rust(), topic, ty, mode)
                .unwrap_or(0)
        })
    }
}

macro_rules! create_group_bin {
    ($($(#[$m:meta])* $name:ident => $method:ident;)*) => {$(
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`.
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            session: *mut uxrSession,
            stream_id: uxrStreamId,
            object_id: uxrObjectId,
            participant_id: uxrObjectId,
            mode: u8,
        ) -> u16 {
            let (stream, object, participant) = (stream_id.rust(), object_id.rust(), participant_id.rust());
            // SAFETY: contract.
            unsafe { with_outputs(session, 0, |mut o| o.$method(stream, object, participant, mode).unwrap_or(0)) }
        }
    )*};
}

create_group_bin! {
    /// `uxr_buffer_create_publisher_bin`.
    uxr_buffer_create_publisher_bin => buffer_create_publisher_bin;
    /// `uxr_buffer_create_subscriber_bin`.
    uxr_buffer_create_subscriber_bin => buffer_create_subscriber_bin;
}

macro_rules! create_endpoint_bin {
    ($($(#[$m:meta])* $name:ident => $method:ident;)*) => {$(
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`.
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            session: *mut uxrSession,
            stream_id: uxrStreamId,
            object_id: uxrObjectId,
            parent_id: uxrObjectId,
            topic_id: uxrObjectId,
            qos: uxrQoS_t,
            mode: u8,
        ) -> u16 {
            let (stream, object, parent, topic) = (stream_id.rust(), object_id.rust(), parent_id.rust(), topic_id.rust());
            // SAFETY: contract.
            unsafe {
                with_outputs(session, 0, |mut o| o.$method(stream, object, parent, topic, qos.rust(), mode).unwrap_or(0))
            }
        }
    )*};
}

create_endpoint_bin! {
    /// `uxr_buffer_create_datawriter_bin`.
    uxr_buffer_create_datawriter_bin => buffer_create_datawriter_bin;
    /// `uxr_buffer_create_datareader_bin`.
    uxr_buffer_create_datareader_bin => buffer_create_datareader_bin;
}

/// The five names of a binary requester or replier; `None` if any is null or not UTF-8.
///
/// # Safety
/// Each null or NUL-terminated, alive for `'n`.
unsafe fn service_names<'n>(names: [*const c_char; 5]) -> Option<ServiceNames<'n>> {
    // SAFETY: contract.
    let [service, request_type, reply_type, request_topic, reply_topic] = names.map(|n| unsafe { text(n) });
    Some(ServiceNames {
        service_name: service?,
        request_type: request_type?,
        reply_type: reply_type?,
        request_topic_name: request_topic?,
        reply_topic_name: reply_topic?,
    })
}

macro_rules! create_service_bin {
    ($($(#[$m:meta])* $name:ident => $method:ident;)*) => {$(
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`; the names null or NUL-terminated.
        #[no_mangle]
        #[allow(clippy::too_many_arguments)]
        pub unsafe extern "C" fn $name(
            session: *mut uxrSession,
            stream_id: uxrStreamId,
            object_id: uxrObjectId,
            participant_id: uxrObjectId,
            service_name: *const c_char,
            request_type: *const c_char,
            reply_type: *const c_char,
            request_topic_name: *const c_char,
            reply_topic_name: *const c_char,
            qos: uxrQoS_t,
            mode: u8,
        ) -> u16 {
            let names = [service_name, request_type, reply_type, request_topic_name, reply_topic_name];
            // SAFETY: contract.
            let Some(names) = (unsafe { service_names(names) }) else { return 0 };
            let (stream, object, participant) = (stream_id.rust(), object_id.rust(), participant_id.rust());
            // SAFETY: contract.
            unsafe {
                with_outputs(session, 0, |mut o| {
                    o.$method(stream, object, participant, &names, qos.rust(), mode).unwrap_or(0)
                })
            }
        }
    )*};
}

create_service_bin! {
    /// `uxr_buffer_create_requester_bin`.
    uxr_buffer_create_requester_bin => buffer_create_requester_bin;
    /// `uxr_buffer_create_replier_bin`.
    uxr_buffer_create_replier_bin => buffer_create_replier_bin;
}

/// `uxr_buffer_delete_entity`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_delete_entity(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    object_id: uxrObjectId,
) -> u16 {
    // SAFETY: contract.
    unsafe { with_outputs(session, 0, |mut o| o.buffer_delete_entity(stream_id.rust(), object_id.rust()).unwrap_or(0)) }
}
