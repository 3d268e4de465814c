//! DDS-XRCE client, wire-compatible with eProsima Micro XRCE-DDS.
//!
//! * [`SessionCore`]: the sans-IO session (`no_std`, no allocation; buffers lent by the caller, stream counts
//!   fixed by const parameters). Bytes and time in, bytes out, callbacks for what the agent says.
//! * [`Session`]: the same over a [`Transport`] with the `run_session_*` family of the C API.
//! * [`transport`]: the transport trait, custom transports (framed or not) and, with `std`, UDP, TCP and
//!   agent discovery, with `serial` (Unix) serial lines and with `can` (Linux) CAN FD.
//! * [`WriteAccess`]: the `uxr_buffer_*` entity and data functions, on both.
//!
//! `docs/client-api.md` maps every `uxr_*` function and constant to its counterpart here.
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod error;
pub mod object;
pub mod session;
pub mod stream;
pub mod transport;

pub use error::{Error, Result};
pub use object::{object_id, DeliveryControl, Durability, History, QoS, Reliability, REPLACE, REUSE};
pub use session::ping::{ping_agent, ping_agent_attempts};
#[cfg(feature = "std")]
pub use session::StdClock;
pub use session::{
    Callbacks, Clock, Outputs, Prepared, Reconnect, ServiceNames, Session, SessionCore, SessionEvent, SessionState,
    TimeSample,
};
pub use transport::{CustomIo, CustomTransport, Transport, TransportError};
pub use xrce_proto::{ObjectId, ObjectKind, SampleIdentity, StreamId, StreamKind};

use xrce_proto::submessage::DataDeliveryControl;

/// Wait without limit (`UXR_TIMEOUT_INF`).
pub const TIMEOUT_INF: i32 = -1;

/// `UXR_STATUS_OK`.
pub const STATUS_OK: u8 = xrce_proto::StatusCode::OK.0;
/// `UXR_STATUS_OK_MATCHED`.
pub const STATUS_OK_MATCHED: u8 = xrce_proto::StatusCode::OK_MATCHED.0;
/// `UXR_STATUS_ERR_DDS_ERROR`.
pub const STATUS_ERR_DDS_ERROR: u8 = xrce_proto::StatusCode::ERR_DDS_ERROR.0;
/// `UXR_STATUS_ERR_MISMATCH`.
pub const STATUS_ERR_MISMATCH: u8 = xrce_proto::StatusCode::ERR_MISMATCH.0;
/// `UXR_STATUS_ERR_ALREADY_EXISTS`.
pub const STATUS_ERR_ALREADY_EXISTS: u8 = xrce_proto::StatusCode::ERR_ALREADY_EXISTS.0;
/// `UXR_STATUS_ERR_DENIED`.
pub const STATUS_ERR_DENIED: u8 = xrce_proto::StatusCode::ERR_DENIED.0;
/// `UXR_STATUS_ERR_UNKNOWN_REFERENCE`.
pub const STATUS_ERR_UNKNOWN_REFERENCE: u8 = xrce_proto::StatusCode::ERR_UNKNOWN_REFERENCE.0;
/// `UXR_STATUS_ERR_INVALID_DATA`.
pub const STATUS_ERR_INVALID_DATA: u8 = xrce_proto::StatusCode::ERR_INVALID_DATA.0;
/// `UXR_STATUS_ERR_INCOMPATIBLE`.
pub const STATUS_ERR_INCOMPATIBLE: u8 = xrce_proto::StatusCode::ERR_INCOMPATIBLE.0;
/// `UXR_STATUS_ERR_RESOURCES`.
pub const STATUS_ERR_RESOURCES: u8 = xrce_proto::StatusCode::ERR_RESOURCES.0;
/// `UXR_STATUS_NONE`: no status received (yet).
pub const STATUS_NONE: u8 = xrce_proto::StatusCode::NONE.0;

/// Direction of a stream (`uxrStreamDirection`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamDirection {
    /// `UXR_INPUT_STREAM`.
    Input,
    /// `UXR_OUTPUT_STREAM`.
    Output,
}

/// `uxr_stream_id`: the id of stream `index` of `kind`. Input and output streams share ids; every function
/// taking a stream knows which direction it means, so `direction` only documents the intent.
pub const fn stream_id(index: u8, kind: StreamKind, direction: StreamDirection) -> StreamId {
    let _ = direction;
    StreamId::from_index(index, kind)
}

/// `uxr_stream_id_from_raw`: the stream of raw id `raw` (0 internal, 1–127 best effort, 128–255 reliable).
pub const fn stream_id_from_raw(raw: u8, direction: StreamDirection) -> StreamId {
    let _ = direction;
    StreamId(raw)
}

/// The `uxr_buffer_*` and `uxr_prepare_output_stream` functions, for [`SessionCore`] and [`Session`].
///
/// Each writes one submessage into an output stream and returns its request id; nothing leaves before the
/// streams are flushed (`flash_output_streams` or any `run_session_*`). On a full reliable history they fail
/// with [`Error::WouldBlock`]: run the session and retry.
pub trait WriteAccess<'a> {
    /// The output streams.
    fn outputs(&mut self) -> Outputs<'_, 'a>;

    /// `uxr_prepare_output_stream`: room for `size` bytes of a sample of `entity`, to serialize in place.
    fn prepare_output_stream<'s>(&'s mut self, stream: StreamId, entity: ObjectId, size: usize) -> Result<Prepared<'s>>
    where
        'a: 's,
    {
        self.outputs().prepare_output_stream(stream, entity, size)
    }
}

macro_rules! delegate {
    ($( $(#[$m:meta])* fn $name:ident(&mut self $(, $arg:ident : $ty:ty)* $(,)?) -> $ret:ty; )*) => {
        /// The entity and data functions, delegated to [`Outputs`].
        pub trait WriteAccessExt<'a>: WriteAccess<'a> {
            $( $(#[$m])* fn $name(&mut self $(, $arg: $ty)*) -> $ret { self.outputs().$name($($arg),*) } )*
        }
        impl<'a, W: WriteAccess<'a> + ?Sized> WriteAccessExt<'a> for W {}
    };
}

delegate! {
    /// `uxr_buffer_create_participant_xml`.
    fn buffer_create_participant_xml(&mut self, stream: StreamId, object: ObjectId, domain: u16, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_topic_xml`.
    fn buffer_create_topic_xml(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_publisher_xml`.
    fn buffer_create_publisher_xml(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_subscriber_xml`.
    fn buffer_create_subscriber_xml(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_datawriter_xml`.
    fn buffer_create_datawriter_xml(&mut self, stream: StreamId, object: ObjectId, publisher: ObjectId, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_datareader_xml`.
    fn buffer_create_datareader_xml(&mut self, stream: StreamId, object: ObjectId, subscriber: ObjectId, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_requester_xml`.
    fn buffer_create_requester_xml(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_replier_xml`.
    fn buffer_create_replier_xml(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, xml: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_participant_ref`.
    fn buffer_create_participant_ref(&mut self, stream: StreamId, object: ObjectId, domain: u16, reference: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_topic_ref`.
    fn buffer_create_topic_ref(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, reference: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_datawriter_ref`.
    fn buffer_create_datawriter_ref(&mut self, stream: StreamId, object: ObjectId, publisher: ObjectId, reference: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_datareader_ref`.
    fn buffer_create_datareader_ref(&mut self, stream: StreamId, object: ObjectId, subscriber: ObjectId, reference: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_requester_ref`.
    fn buffer_create_requester_ref(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, reference: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_replier_ref`.
    fn buffer_create_replier_ref(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, reference: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_participant_bin`.
    fn buffer_create_participant_bin(&mut self, stream: StreamId, object: ObjectId, domain: u16, name: Option<&str>, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_topic_bin`.
    fn buffer_create_topic_bin(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, topic_name: &str, type_name: &str, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_publisher_bin`.
    fn buffer_create_publisher_bin(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_subscriber_bin`.
    fn buffer_create_subscriber_bin(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_datawriter_bin`.
    fn buffer_create_datawriter_bin(&mut self, stream: StreamId, object: ObjectId, publisher: ObjectId, topic: ObjectId, qos: QoS, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_datareader_bin`.
    fn buffer_create_datareader_bin(&mut self, stream: StreamId, object: ObjectId, subscriber: ObjectId, topic: ObjectId, qos: QoS, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_requester_bin`.
    fn buffer_create_requester_bin(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, service: &ServiceNames<'_>, qos: QoS, mode: u8) -> Result<u16>;
    /// `uxr_buffer_create_replier_bin`.
    fn buffer_create_replier_bin(&mut self, stream: StreamId, object: ObjectId, participant: ObjectId, service: &ServiceNames<'_>, qos: QoS, mode: u8) -> Result<u16>;
    /// `uxr_buffer_delete_entity`.
    fn buffer_delete_entity(&mut self, stream: StreamId, object: ObjectId) -> Result<u16>;
    /// `uxr_buffer_request_data`.
    fn buffer_request_data(&mut self, stream: StreamId, reader: ObjectId, data_stream: StreamId, control: Option<&DataDeliveryControl>) -> Result<u16>;
    /// `uxr_buffer_cancel_data`.
    fn buffer_cancel_data(&mut self, stream: StreamId, reader: ObjectId) -> Result<u16>;
    /// `uxr_buffer_topic`.
    fn buffer_topic(&mut self, stream: StreamId, writer: ObjectId, data: &[u8]) -> Result<u16>;
    /// `uxr_buffer_request`.
    fn buffer_request(&mut self, stream: StreamId, requester: ObjectId, data: &[u8]) -> Result<u16>;
    /// `uxr_buffer_reply`.
    fn buffer_reply(&mut self, stream: StreamId, replier: ObjectId, sample_id: &SampleIdentity, data: &[u8]) -> Result<u16>;
}

impl<'a, const OBE: usize, const ORE: usize, const IBE: usize, const IRE: usize> WriteAccess<'a>
    for SessionCore<'a, OBE, ORE, IBE, IRE>
{
    fn outputs(&mut self) -> Outputs<'_, 'a> {
        SessionCore::outputs(self)
    }
}

/// Everything an application needs in scope.
pub mod prelude {
    pub use crate::session::ping::{ping_agent, ping_agent_attempts};
    #[cfg(all(feature = "can", target_os = "linux"))]
    pub use crate::transport::CanTransport;
    #[cfg(feature = "std")]
    pub use crate::transport::{discovery, IpProtocol, TcpTransport, UdpTransport};
    pub use crate::transport::{CustomIo, CustomTransport, Transport};
    #[cfg(all(feature = "serial", unix))]
    pub use crate::transport::{SerialSettings, SerialTransport};
    #[cfg(feature = "std")]
    pub use crate::StdClock;
    pub use crate::{
        object_id, stream_id, stream_id_from_raw, Callbacks, DeliveryControl, Durability, Error, History, ObjectId,
        ObjectKind, Outputs, QoS, Reconnect, Reliability, SampleIdentity, ServiceNames, Session, SessionCore,
        SessionEvent, StreamDirection, StreamId, StreamKind, WriteAccess, WriteAccessExt, REPLACE, REUSE, STATUS_NONE,
        STATUS_OK, STATUS_OK_MATCHED, TIMEOUT_INF,
    };
}
