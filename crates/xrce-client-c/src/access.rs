//! Read and write access: `uxr_buffer_request_data`, `uxr_buffer_cancel_data`, `uxr_prepare_output_stream`,
//! `uxr_buffer_topic` / `_request` / `_reply`, and the identifier helpers.

use xrce_client::StreamId;

use crate::abi::{uxrDeliveryControl, uxrObjectId, uxrStreamId, BEST_EFFORT_STREAM, RELIABLE_STREAM};
use crate::session::{uxrSession, with_outputs};
use crate::types::SampleIdentity;
use crate::ucdr::buffer::{ucdrBuffer, LITTLE};

/// `uxr_buffer_request_data`: a null `control` asks for one sample.
///
/// # Safety
/// `session` null or a `uxrSession`; `control` null or readable.
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_request_data(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    datareader_id: uxrObjectId,
    data_stream_id: uxrStreamId,
    control: *const uxrDeliveryControl,
) -> u16 {
    // SAFETY: contract.
    let control = unsafe { control.as_ref() }.map(|c| c.rust());
    // SAFETY: contract.
    unsafe {
        with_outputs(session, 0, |mut o| {
            o.buffer_request_data(stream_id.rust(), datareader_id.rust(), data_stream_id.rust(), control.as_ref())
                .unwrap_or(0)
        })
    }
}

/// `uxr_buffer_cancel_data`.
///
/// # Safety
/// `session` null or a `uxrSession`.
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_cancel_data(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    datareader_id: uxrObjectId,
) -> u16 {
    // SAFETY: contract.
    unsafe {
        with_outputs(session, 0, |mut o| o.buffer_cancel_data(stream_id.rust(), datareader_id.rust()).unwrap_or(0))
    }
}

/// What the closure of `uxr_prepare_output_stream` returns when the bytes are not reserved.
const FAILED: u32 = 0x1_0000;
/// As [`FAILED`], for a sample larger than one message.
const TOO_LARGE: u32 = 0x2_0000;

/// `uxr_prepare_output_stream`: reserves `data_size` bytes in the stream and points `ub` at them (zeroed; all
/// are sent whatever is written). On a reliable stream, a sample larger than one message is spread over the
/// stream's slots as fragments, as eProsima's library does: `ub` then fills a window at a time (its on-full
/// callback) and the sample must fit the stream's free history whole. 0 when the bytes do not fit, with `ub`
/// left empty (its writes fail).
///
/// # Safety
/// `session` null or a `uxrSession`; `ub` null or writable. The program serializes into `ub` before the next
/// call on the session, as the seed describes.
#[no_mangle]
pub unsafe extern "C" fn uxr_prepare_output_stream(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    entity_id: uxrObjectId,
    ub: *mut ucdrBuffer,
    data_size: u32,
) -> u16 {
    if ub.is_null() {
        return 0;
    }
    let size = usize::try_from(data_size).unwrap_or(usize::MAX);
    // The stream's lock is taken before the bytes are reserved and kept until the program's
    // UXR_UNLOCK_STREAM_ID (multithread profile): no other thread sends them half-written.
    #[cfg(uxr_multithread)]
    // SAFETY: contract (a session, or null: no lock).
    unsafe {
        crate::lock::hold_stream(session, stream_id);
    }
    // The closure points `ub` at the slot itself and returns the request id, or one of two codes above any id:
    // a `u32` in a register, not a `Result` of three words through memory (firmware size).
    // SAFETY: contract. `ub` non-null and writable. The slot lies in the stream memory the program lent to the
    // session; the session does not touch it again before the program's next call on it, by which time the
    // program has serialized into it.
    let prepared = unsafe {
        with_outputs(session, FAILED, |o| match o.prepare_output_stream(stream_id.rust(), entity_id.rust(), size) {
            Ok(mut p) => {
                let buf = p.buffer();
                ub.write(ucdrBuffer::over(buf.as_mut_ptr(), buf.len(), 0, 0, LITTLE));
                u32::from(p.request_id)
            }
            Err(xrce_client::Error::TooLarge) => TOO_LARGE,
            Err(_) => FAILED,
        })
    };
    if prepared == TOO_LARGE && stream_id.type_ == RELIABLE_STREAM {
        // SAFETY: contract.
        let request = unsafe { crate::session::prepare_whole(session, stream_id, entity_id, ub, size) };
        // The fragmented write took its own hold on the stream.
        #[cfg(uxr_multithread)]
        // SAFETY: taken above by this thread.
        unsafe {
            crate::lock::release_stream(session, stream_id);
        }
        return request;
    }
    let request = u16::try_from(prepared).unwrap_or(0);
    if prepared > u32::from(u16::MAX) {
        // SAFETY: `ub` non-null and writable (contract): an empty buffer, its writes fail.
        unsafe { ub.write(ucdrBuffer::over(core::ptr::null_mut(), 0, 0, 0, LITTLE)) };
    }
    #[cfg(uxr_multithread)]
    if request == 0 {
        // SAFETY: taken above by this thread.
        unsafe { crate::lock::release_stream(session, stream_id) };
    }
    request
}

/// `len` bytes at `buffer`, or `None` for null with a length.
///
/// # Safety
/// `buffer` null or `len` readable bytes.
unsafe fn bytes<'b>(buffer: *const u8, len: usize) -> Option<&'b [u8]> {
    if len == 0 {
        return Some(&[]);
    }
    // SAFETY: contract.
    (!buffer.is_null()).then(|| unsafe { core::slice::from_raw_parts(buffer, len) })
}

macro_rules! buffer_data {
    ($($(#[$m:meta])* $name:ident => $method:ident;)*) => {$(
        $(#[$m])*
        ///
        /// # Safety
        /// `session` null or a `uxrSession`; `buffer` null or `len` readable bytes.
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            session: *mut uxrSession,
            stream_id: uxrStreamId,
            entity_id: uxrObjectId,
            buffer: *const u8,
            len: usize,
        ) -> u16 {
            // SAFETY: contract.
            let Some(data) = (unsafe { bytes(buffer, len) }) else { return 0 };
            // SAFETY: contract.
            unsafe { with_outputs(session, 0, |mut o| o.$method(stream_id.rust(), entity_id.rust(), data).unwrap_or(0)) }
        }
    )*};
}

buffer_data! {
    /// `uxr_buffer_topic`: the request id (0 on failure, so it reads as the seed's `bool`). Reliable streams
    /// fragment samples larger than a message.
    uxr_buffer_topic => buffer_topic;
    /// `uxr_buffer_request`: the request id, which comes back as `reply_id` in the reply callback.
    uxr_buffer_request => buffer_request;
}

/// `uxr_buffer_reply`: answers the request `sample_id` (from the request callback).
///
/// # Safety
/// As [`uxr_buffer_topic`]; `sample_id` null or readable.
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_reply(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    replier_id: uxrObjectId,
    sample_id: *const SampleIdentity,
    buffer: *const u8,
    len: usize,
) -> u16 {
    // SAFETY: contract.
    let (Some(data), Some(sample)) = (unsafe { (bytes(buffer, len), sample_id.as_ref()) }) else { return 0 };
    let sample = sample.rust();
    // SAFETY: contract.
    unsafe {
        with_outputs(session, 0, |mut o| {
            o.buffer_reply(stream_id.rust(), replier_id.rust(), &sample, data).unwrap_or(0)
        })
    }
}

/// `uxr_buffer_reply` as the seed's text writes it (no request identity): answers the last request the
/// session received; 0 when none was. client.h picks it by argument count.
///
/// # Safety
/// As [`uxr_buffer_reply`].
#[no_mangle]
pub unsafe extern "C" fn uxr_buffer_reply_last(
    session: *mut uxrSession,
    stream_id: uxrStreamId,
    replier_id: uxrObjectId,
    buffer: *const u8,
    len: usize,
) -> u16 {
    // SAFETY: contract.
    let Some(sample) = (unsafe { crate::session::last_request(session) }) else { return 0 };
    // SAFETY: contract; `sample` lives for the call.
    unsafe { uxr_buffer_reply(session, stream_id, replier_id, &sample, buffer, len) }
}

/// `uxr_stream_id`.
#[no_mangle]
pub extern "C" fn uxr_stream_id(index: u8, type_: u32, direction: u32) -> uxrStreamId {
    let raw = match u8::try_from(type_) {
        Ok(BEST_EFFORT_STREAM) => StreamId::from_index(index, xrce_client::StreamKind::BestEffort),
        Ok(RELIABLE_STREAM) => StreamId::from_index(index, xrce_client::StreamKind::Reliable),
        _ => StreamId::NONE,
    };
    uxrStreamId::from_rust(raw, direction)
}

/// `uxr_stream_id_from_raw`.
#[no_mangle]
pub extern "C" fn uxr_stream_id_from_raw(raw: u8, direction: u32) -> uxrStreamId {
    uxrStreamId::from_rust(StreamId(raw), direction)
}

/// `uxr_object_id`.
#[no_mangle]
pub extern "C" fn uxr_object_id(id: u16, type_: u8) -> uxrObjectId {
    uxrObjectId { id, type_ }
}

/// `uxr_object_id_from_raw`: the object id of the wire's two bytes (a null pointer gives the invalid id).
///
/// # Safety
/// `raw` null or two readable bytes.
#[no_mangle]
pub unsafe extern "C" fn uxr_object_id_from_raw(raw: *const u8) -> uxrObjectId {
    if raw.is_null() {
        return uxrObjectId { id: 0, type_: 0 };
    }
    // SAFETY: two readable bytes (contract).
    let bytes = unsafe { [raw.read(), raw.add(1).read()] };
    uxrObjectId::from_rust(xrce_client::ObjectId(bytes))
}

/// `uxr_object_id_to_raw`: the wire's two bytes of `object_id` into `raw`.
///
/// # Safety
/// `raw` null or two writable bytes.
#[no_mangle]
pub unsafe extern "C" fn uxr_object_id_to_raw(object_id: uxrObjectId, raw: *mut u8) {
    if raw.is_null() {
        return;
    }
    let [hi, lo] = object_id.rust().0;
    // SAFETY: two writable bytes (contract).
    unsafe {
        raw.write(hi);
        raw.add(1).write(lo);
    }
}
