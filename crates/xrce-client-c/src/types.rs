//! The XRCE types of `uxr/client/core/type/xrce_types.h` that programs use (time, keys, object ids, locators,
//! RTPS GUIDs, sample identities), field for field (build.rs checks every offset against the header), and their
//! CDR serializers `uxr_serialize_<Type>` / `uxr_deserialize_<Type>`: the buffer's endianness, CDR alignment,
//! `false` (and the buffer's `error` set) when a value does not fit.

#![allow(non_camel_case_types, non_snake_case)]

use core::ffi::c_char;

use crate::ucdr::buffer::{buffer_mut, ucdrBuffer};
use crate::ucdr::primitives as p;

/// `UXR_BINARY_SEQUENCE_MAX`.
pub const BINARY_SEQUENCE_MAX: usize = 512;
/// `UXR_STRING_SEQUENCE_MAX`.
pub const STRING_SEQUENCE_MAX: usize = 8;
/// `UXR_STRING_SIZE_MAX`: room a deserialized string's memory must have.
pub const STRING_SIZE_MAX: usize = 512;
/// `UXR_TRANSPORT_LOCATOR_SEQUENCE_MAX`.
pub const TRANSPORT_LOCATOR_SEQUENCE_MAX: usize = 4;

/// `ADDRESS_FORMAT_SMALL`.
pub const ADDRESS_FORMAT_SMALL: u8 = 0;
/// `ADDRESS_FORMAT_MEDIUM` (IPv4).
pub const ADDRESS_FORMAT_MEDIUM: u8 = 1;
/// `ADDRESS_FORMAT_LARGE` (IPv6).
pub const ADDRESS_FORMAT_LARGE: u8 = 2;
/// `ADDRESS_FORMAT_STRING`.
pub const ADDRESS_FORMAT_STRING: u8 = 3;

/// `Time_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Time_t {
    /// Seconds.
    pub seconds: i32,
    /// Nanoseconds.
    pub nanoseconds: u32,
}

/// `BinarySequence_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct BinarySequence_t {
    /// Bytes used.
    pub size: u32,
    /// The bytes.
    pub data: [u8; BINARY_SEQUENCE_MAX],
}

/// `StringSequence_t`: strings the program owns.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct StringSequence_t {
    /// Strings used.
    pub size: u32,
    /// NUL-terminated strings (deserializing writes into them: `UXR_STRING_SIZE_MAX` bytes each).
    pub data: [*mut c_char; STRING_SEQUENCE_MAX],
}

macro_rules! bytes_type {
    ($($(#[$m:meta])* $name:ident, $n:literal;)*) => {$(
        $(#[$m])*
        #[repr(C)]
        #[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
        pub struct $name {
            /// The bytes.
            pub data: [u8; $n],
        }
    )*};
}

bytes_type! {
    /// `ClientKey`.
    ClientKey, 4;
    /// `ObjectId` (the wire's two bytes).
    ObjectId, 2;
    /// `ObjectPrefix`.
    ObjectPrefix, 2;
    /// `XrceCookie`.
    XrceCookie, 4;
    /// `XrceVersion`.
    XrceVersion, 2;
    /// `XrceVendorId`.
    XrceVendorId, 2;
}

/// `TransportLocatorSmall`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TransportLocatorSmall {
    /// Address.
    pub address: [u8; 2],
    /// Port.
    pub locator_port: u8,
}

/// `TransportLocatorMedium` (IPv4).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TransportLocatorMedium {
    /// Address.
    pub address: [u8; 4],
    /// Port.
    pub locator_port: u16,
}

/// `TransportLocatorLarge` (IPv6).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TransportLocatorLarge {
    /// Address.
    pub address: [u8; 16],
    /// Port.
    pub locator_port: u32,
}

/// `TransportLocatorString`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TransportLocatorString {
    /// NUL-terminated text the program owns.
    pub value: *mut c_char,
}

/// `TransportLocatorU`.
#[repr(C)]
#[derive(Clone, Copy)]
pub union TransportLocatorU {
    /// `ADDRESS_FORMAT_SMALL`.
    pub small_locator: TransportLocatorSmall,
    /// `ADDRESS_FORMAT_MEDIUM`.
    pub medium_locator: TransportLocatorMedium,
    /// `ADDRESS_FORMAT_LARGE`.
    pub large_locator: TransportLocatorLarge,
    /// `ADDRESS_FORMAT_STRING`.
    pub string_locator: TransportLocatorString,
}

/// `TransportLocator`: `format` says which member of `_` (here `_u`) holds the address.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct TransportLocator {
    /// `ADDRESS_FORMAT_*`.
    pub format: u8,
    /// The address (`_` in C).
    pub _u: TransportLocatorU,
}

impl core::fmt::Debug for TransportLocator {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TransportLocator").field("format", &self.format).finish_non_exhaustive()
    }
}

impl TransportLocator {
    /// An IPv4 locator.
    pub const fn medium(address: [u8; 4], port: u16) -> Self {
        Self {
            format: ADDRESS_FORMAT_MEDIUM,
            _u: TransportLocatorU { medium_locator: TransportLocatorMedium { address, locator_port: port } },
        }
    }

    /// An IPv6 locator.
    pub const fn large(address: [u8; 16], port: u16) -> Self {
        Self {
            format: ADDRESS_FORMAT_LARGE,
            _u: TransportLocatorU { large_locator: TransportLocatorLarge { address, locator_port: port as u32 } },
        }
    }
}

/// `TransportLocatorSeq`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TransportLocatorSeq {
    /// Locators used.
    pub size: u32,
    /// The locators.
    pub data: [TransportLocator; TRANSPORT_LOCATOR_SEQUENCE_MAX],
}

/// `GuidPrefix_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GuidPrefix_t {
    /// The prefix.
    pub data: [u8; 12],
}

/// `EntityId_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EntityId_t {
    /// Key.
    pub entityKey: [u8; 3],
    /// Kind.
    pub entityKind: u8,
}

/// `GUID_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GUID_t {
    /// Participant prefix.
    pub guidPrefix: GuidPrefix_t,
    /// Entity.
    pub entityId: EntityId_t,
}

/// `SequenceNumber_t`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SequenceNumber_t {
    /// High 32 bits.
    pub high: i32,
    /// Low 32 bits.
    pub low: u32,
}

/// `SampleIdentity` (24 bytes, alignment 4): the writer and sequence number of a request.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SampleIdentity {
    /// The writer.
    pub writer_guid: GUID_t,
    /// Its sample.
    pub sequence_number: SequenceNumber_t,
}

impl SampleIdentity {
    /// The C form.
    pub const fn from_rust(s: &xrce_proto::SampleIdentity) -> Self {
        Self {
            writer_guid: GUID_t {
                guidPrefix: GuidPrefix_t { data: s.writer_guid.prefix },
                entityId: EntityId_t { entityKey: s.writer_guid.entity_key, entityKind: s.writer_guid.entity_kind },
            },
            sequence_number: SequenceNumber_t { high: s.sequence_number.high, low: s.sequence_number.low },
        }
    }

    /// The Rust form.
    pub const fn rust(&self) -> xrce_proto::SampleIdentity {
        xrce_proto::SampleIdentity {
            writer_guid: xrce_proto::Guid {
                prefix: self.writer_guid.guidPrefix.data,
                entity_key: self.writer_guid.entityId.entityKey,
                entity_kind: self.writer_guid.entityId.entityKind,
            },
            sequence_number: xrce_proto::SequenceNumber {
                high: self.sequence_number.high,
                low: self.sequence_number.low,
            },
        }
    }
}

// ---- serializers --------------------------------------------------------------------------------------------

/// Serialization of one type: `ser` writes `&T`, `de` reads into `&mut T`, both through the buffer.
trait Cdr: Sized {
    /// # Safety
    /// `ub` a valid buffer (its memory lent by the program).
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool;
    /// # Safety
    /// As `ser`.
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool;
}

/// Serializes fixed bytes.
///
/// # Safety
/// `ub` a valid buffer.
unsafe fn put_bytes(ub: *mut ucdrBuffer, bytes: &[u8]) -> bool {
    // SAFETY: contract; `bytes` readable for its length.
    unsafe { p::ucdr_serialize_array_uint8_t(ub, bytes.as_ptr(), bytes.len()) }
}

/// Deserializes fixed bytes.
///
/// # Safety
/// `ub` a valid buffer.
unsafe fn get_bytes(ub: *mut ucdrBuffer, bytes: &mut [u8]) -> bool {
    // SAFETY: contract; `bytes` writable for its length.
    unsafe { p::ucdr_deserialize_array_uint8_t(ub, bytes.as_mut_ptr(), bytes.len()) }
}

macro_rules! cdr_bytes {
    ($($t:ty),*) => {$(
        impl Cdr for $t {
            unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
                // SAFETY: contract.
                unsafe { put_bytes(ub, &self.data) }
            }
            unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
                // SAFETY: contract.
                unsafe { get_bytes(ub, &mut self.data) }
            }
        }
    )*};
}
cdr_bytes!(ClientKey, ObjectId, ObjectPrefix, XrceCookie, XrceVersion, XrceVendorId, GuidPrefix_t);

impl Cdr for Time_t {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { p::ucdr_serialize_int32_t(ub, self.seconds) && p::ucdr_serialize_uint32_t(ub, self.nanoseconds) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract; the fields are writable.
        unsafe {
            p::ucdr_deserialize_int32_t(ub, &mut self.seconds)
                && p::ucdr_deserialize_uint32_t(ub, &mut self.nanoseconds)
        }
    }
}

impl Cdr for BinarySequence_t {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        let len = usize::try_from(self.size).unwrap_or(usize::MAX).min(BINARY_SEQUENCE_MAX);
        // SAFETY: contract; `data` holds at least `len` bytes.
        unsafe { p::ucdr_serialize_sequence_uint8_t(ub, self.data.as_ptr(), u32::try_from(len).unwrap_or(0)) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract; `data` writable for its capacity.
        unsafe { p::ucdr_deserialize_sequence_uint8_t(ub, self.data.as_mut_ptr(), BINARY_SEQUENCE_MAX, &mut self.size) }
    }
}

impl Cdr for StringSequence_t {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        let n = usize::try_from(self.size).unwrap_or(usize::MAX);
        if n > STRING_SEQUENCE_MAX {
            return fail(ub);
        }
        // SAFETY: contract.
        let mut ok = unsafe { p::ucdr_serialize_uint32_t(ub, self.size) };
        for s in self.data.iter().take(n) {
            // SAFETY: contract: each used string is NUL-terminated (null fails).
            ok = ok && unsafe { p::ucdr_serialize_string(ub, *s) };
        }
        ok
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        let mut size = 0u32;
        // SAFETY: contract.
        if !unsafe { p::ucdr_deserialize_uint32_t(ub, &mut size) } {
            return false;
        }
        if usize::try_from(size).map_or(true, |n| n > STRING_SEQUENCE_MAX) {
            return fail(ub);
        }
        self.size = size;
        let mut ok = true;
        for s in self.data.iter().take(usize::try_from(size).unwrap_or(0)) {
            // SAFETY: contract: each string has UXR_STRING_SIZE_MAX writable bytes (null fails).
            ok = ok && unsafe { p::ucdr_deserialize_string(ub, *s, STRING_SIZE_MAX) };
        }
        ok
    }
}

/// Marks `ub` failed.
fn fail(ub: *mut ucdrBuffer) -> bool {
    // SAFETY: callers pass the buffer they were given, valid or null.
    if let Some(b) = unsafe { buffer_mut(ub) } {
        b.error = true;
    }
    false
}

impl Cdr for TransportLocatorSmall {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { put_bytes(ub, &self.address) && p::ucdr_serialize_uint8_t(ub, self.locator_port) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { get_bytes(ub, &mut self.address) && p::ucdr_deserialize_uint8_t(ub, &mut self.locator_port) }
    }
}

impl Cdr for TransportLocatorMedium {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { put_bytes(ub, &self.address) && p::ucdr_serialize_uint16_t(ub, self.locator_port) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { get_bytes(ub, &mut self.address) && p::ucdr_deserialize_uint16_t(ub, &mut self.locator_port) }
    }
}

impl Cdr for TransportLocatorLarge {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { put_bytes(ub, &self.address) && p::ucdr_serialize_uint32_t(ub, self.locator_port) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { get_bytes(ub, &mut self.address) && p::ucdr_deserialize_uint32_t(ub, &mut self.locator_port) }
    }
}

impl Cdr for TransportLocatorString {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract: NUL-terminated or null (fails).
        unsafe { p::ucdr_serialize_string(ub, self.value) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract: UXR_STRING_SIZE_MAX writable bytes or null (fails).
        unsafe { p::ucdr_deserialize_string(ub, self.value, STRING_SIZE_MAX) }
    }
}

impl Cdr for TransportLocator {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract; the union member read is the one `format` names (the program's promise, as in C).
        unsafe {
            p::ucdr_serialize_uint8_t(ub, self.format)
                && match self.format {
                    ADDRESS_FORMAT_SMALL => self._u.small_locator.ser(ub),
                    ADDRESS_FORMAT_MEDIUM => self._u.medium_locator.ser(ub),
                    ADDRESS_FORMAT_LARGE => self._u.large_locator.ser(ub),
                    ADDRESS_FORMAT_STRING => self._u.string_locator.ser(ub),
                    _ => fail(ub),
                }
        }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract; each arm writes the member `format` names (plain data, any bit pattern valid).
        unsafe {
            p::ucdr_deserialize_uint8_t(ub, &mut self.format)
                && match self.format {
                    ADDRESS_FORMAT_SMALL => self._u.small_locator.de(ub),
                    ADDRESS_FORMAT_MEDIUM => self._u.medium_locator.de(ub),
                    ADDRESS_FORMAT_LARGE => self._u.large_locator.de(ub),
                    ADDRESS_FORMAT_STRING => self._u.string_locator.de(ub),
                    _ => fail(ub),
                }
        }
    }
}

impl Cdr for TransportLocatorSeq {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        let n = usize::try_from(self.size).unwrap_or(usize::MAX);
        if n > TRANSPORT_LOCATOR_SEQUENCE_MAX {
            return fail(ub);
        }
        // SAFETY: contract.
        let mut ok = unsafe { p::ucdr_serialize_uint32_t(ub, self.size) };
        for l in self.data.iter().take(n) {
            // SAFETY: contract.
            ok = ok && unsafe { l.ser(ub) };
        }
        ok
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        let mut size = 0u32;
        // SAFETY: contract.
        if !unsafe { p::ucdr_deserialize_uint32_t(ub, &mut size) } {
            return false;
        }
        if usize::try_from(size).map_or(true, |n| n > TRANSPORT_LOCATOR_SEQUENCE_MAX) {
            return fail(ub);
        }
        self.size = size;
        let mut ok = true;
        for l in self.data.iter_mut().take(usize::try_from(size).unwrap_or(0)) {
            // SAFETY: contract.
            ok = ok && unsafe { l.de(ub) };
        }
        ok
    }
}

impl Cdr for EntityId_t {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { put_bytes(ub, &self.entityKey) && p::ucdr_serialize_uint8_t(ub, self.entityKind) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { get_bytes(ub, &mut self.entityKey) && p::ucdr_deserialize_uint8_t(ub, &mut self.entityKind) }
    }
}

impl Cdr for GUID_t {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { self.guidPrefix.ser(ub) && self.entityId.ser(ub) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { self.guidPrefix.de(ub) && self.entityId.de(ub) }
    }
}

impl Cdr for SequenceNumber_t {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { p::ucdr_serialize_int32_t(ub, self.high) && p::ucdr_serialize_uint32_t(ub, self.low) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { p::ucdr_deserialize_int32_t(ub, &mut self.high) && p::ucdr_deserialize_uint32_t(ub, &mut self.low) }
    }
}

impl Cdr for SampleIdentity {
    unsafe fn ser(&self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { self.writer_guid.ser(ub) && self.sequence_number.ser(ub) }
    }
    unsafe fn de(&mut self, ub: *mut ucdrBuffer) -> bool {
        // SAFETY: contract.
        unsafe { self.writer_guid.de(ub) && self.sequence_number.de(ub) }
    }
}

macro_rules! serializers {
    ($($t:ident),* $(,)?) => {pastey::paste! {$(
        #[doc = concat!("`uxr_serialize_", stringify!($t), "`.")]
        ///
        /// # Safety
        /// `buffer` null or a valid `ucdrBuffer`; `input` null or readable (strings it points to NUL-terminated).
        #[no_mangle]
        pub unsafe extern "C" fn [<uxr_serialize_ $t>](buffer: *mut ucdrBuffer, input: *const $t) -> bool {
            // SAFETY: contract.
            match unsafe { (buffer_mut(buffer).is_some(), input.as_ref()) } {
                // SAFETY: contract.
                (true, Some(v)) => unsafe { v.ser(buffer) },
                _ => fail(buffer),
            }
        }

        #[doc = concat!("`uxr_deserialize_", stringify!($t), "`.")]
        ///
        /// # Safety
        /// `buffer` null or a valid `ucdrBuffer`; `output` null or writable (strings: `UXR_STRING_SIZE_MAX` bytes).
        #[no_mangle]
        pub unsafe extern "C" fn [<uxr_deserialize_ $t>](buffer: *mut ucdrBuffer, output: *mut $t) -> bool {
            // SAFETY: contract.
            match unsafe { (buffer_mut(buffer).is_some(), output.as_mut()) } {
                // SAFETY: contract.
                (true, Some(v)) => unsafe { v.de(buffer) },
                _ => fail(buffer),
            }
        }
    )*}};
}

serializers!(
    Time_t,
    BinarySequence_t,
    StringSequence_t,
    ClientKey,
    ObjectId,
    ObjectPrefix,
    XrceCookie,
    XrceVersion,
    XrceVendorId,
    TransportLocatorSmall,
    TransportLocatorMedium,
    TransportLocatorLarge,
    TransportLocatorString,
    TransportLocator,
    TransportLocatorSeq,
    GuidPrefix_t,
    EntityId_t,
    GUID_t,
    SequenceNumber_t,
    SampleIdentity,
);
