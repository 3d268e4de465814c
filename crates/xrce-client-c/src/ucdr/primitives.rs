//! Serialization of every primitive, alone, with an explicit endianness, as fixed arrays and as sequences,
//! and of strings: the `ucdr_(de)serialize_*` functions.

use core::ffi::{c_char, CStr};

use super::buffer::{buffer_mut, ucdrBuffer, BIG};

/// A CDR primitive: its size (also its alignment) and its bytes in either byte order.
trait Primitive: Copy {
    const SIZE: usize;
    fn put(self, big: bool, out: &mut [u8; 8]);
    fn get(big: bool, bytes: &[u8; 8]) -> Self;
}

macro_rules! numeric {
    ($($t:ty => $n:literal),* $(,)?) => {$(
        impl Primitive for $t {
            const SIZE: usize = $n;
            fn put(self, big: bool, out: &mut [u8; 8]) {
                let b = if big { self.to_be_bytes() } else { self.to_le_bytes() };
                // A whole array assigned: one store, not a byte loop (firmware size).
                if let Some(dst) = out.first_chunk_mut::<$n>() {
                    *dst = b;
                }
            }
            fn get(big: bool, bytes: &[u8; 8]) -> Self {
                let b = bytes.first_chunk::<$n>().copied().unwrap_or([0; $n]);
                if big { <$t>::from_be_bytes(b) } else { <$t>::from_le_bytes(b) }
            }
        }
    )*};
}

numeric!(i8 => 1, u8 => 1, i16 => 2, u16 => 2, i32 => 4, u32 => 4, i64 => 8, u64 => 8, f32 => 4, f64 => 8);

impl Primitive for bool {
    const SIZE: usize = 1;
    fn put(self, _big: bool, out: &mut [u8; 8]) {
        out[0] = u8::from(self);
    }
    fn get(_big: bool, bytes: &[u8; 8]) -> Self {
        bytes[0] != 0
    }
}

/// Writes `value` aligned to its size; `false` (and `error` set) when it does not fit.
fn write<T: Primitive>(ub: &mut ucdrBuffer, endianness: u32, value: T) -> bool {
    let mut bytes = [0u8; 8];
    value.put(endianness == BIG, &mut bytes);
    let Some(at) = ub.take(T::SIZE, T::SIZE) else { return false };
    // SAFETY: `take` checked that `T::SIZE` bytes from `at` lie inside the buffer's memory, which the C
    // program lent for writing when it set the buffer up.
    unsafe { core::ptr::copy_nonoverlapping(bytes.as_ptr(), at, T::SIZE) };
    true
}

/// Reads a value aligned to its size; `None` (and `error` set) when the buffer ends first.
fn read<T: Primitive>(ub: &mut ucdrBuffer, endianness: u32) -> Option<T> {
    let at = ub.take(T::SIZE, T::SIZE)?;
    let mut bytes = [0u8; 8];
    // SAFETY: `take` checked that `T::SIZE` bytes from `at` lie inside the buffer's memory.
    unsafe { core::ptr::copy_nonoverlapping(at, bytes.as_mut_ptr(), T::SIZE) };
    Some(T::get(endianness == BIG, &bytes))
}

/// Writes `len` elements from `array`.
///
/// # Safety
/// `array` is null only with `len` 0, else holds `len` elements.
unsafe fn write_array<T: Primitive>(ub: &mut ucdrBuffer, endianness: u32, array: *const T, len: usize) -> bool {
    if len == 0 {
        return true;
    }
    if array.is_null() {
        ub.error = true;
        return false;
    }
    // SAFETY: non-null and holding `len` elements (contract).
    let items = unsafe { core::slice::from_raw_parts(array, len) };
    items.iter().all(|&v| write(ub, endianness, v))
}

/// Reads `len` elements into `array`.
///
/// # Safety
/// `array` is null only with `len` 0, else has room for `len` elements.
unsafe fn read_array<T: Primitive>(ub: &mut ucdrBuffer, endianness: u32, array: *mut T, len: usize) -> bool {
    if len == 0 {
        return true;
    }
    if array.is_null() {
        ub.error = true;
        return false;
    }
    // SAFETY: non-null with room for `len` elements (contract); `T` has no invalid bit patterns but `bool`,
    // which is only ever written here as `true` or `false`.
    let items = unsafe { core::slice::from_raw_parts_mut(array, len) };
    for item in items {
        match read(ub, endianness) {
            Some(v) => *item = v,
            None => return false,
        }
    }
    true
}

/// Reads a sequence's length, then up to `capacity` elements; more than that is an error.
///
/// # Safety
/// `array` has room for `capacity` elements (or is null with `capacity` 0); `length` null or writable.
unsafe fn read_sequence<T: Primitive>(
    ub: &mut ucdrBuffer,
    endianness: u32,
    array: *mut T,
    capacity: usize,
    length: *mut u32,
) -> bool {
    let Some(len) = read::<u32>(ub, endianness) else { return false };
    // SAFETY: null or writable (contract).
    if let Some(out) = unsafe { length.as_mut() } {
        *out = len;
    }
    let len = usize::try_from(len).unwrap_or(usize::MAX);
    if len > capacity {
        ub.error = true;
        return false;
    }
    // SAFETY: `len <= capacity` elements fit in `array` (contract).
    unsafe { read_array(ub, endianness, array, len) }
}

macro_rules! primitive_functions {
    ($($name:ident : $t:ty),* $(,)?) => { pastey::paste! {$(
        #[doc = concat!("`ucdr_serialize_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_serialize_ $name>](ub: *mut ucdrBuffer, value: $t) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub| { let e = ub.endianness; write(ub, e, value) })
        }

        #[doc = concat!("`ucdr_serialize_endian_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_serialize_endian_ $name>](ub: *mut ucdrBuffer, endianness: u32, value: $t) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub| write(ub, endianness, value))
        }

        #[doc = concat!("`ucdr_deserialize_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid; `value` null or writable.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_deserialize_ $name>](ub: *mut ucdrBuffer, value: *mut $t) -> bool {
            // SAFETY: contract.
            let e = unsafe { ub.as_ref() }.map_or(BIG, |b| b.endianness);
            // SAFETY: contract.
            unsafe { [<ucdr_deserialize_endian_ $name>](ub, e, value) }
        }

        #[doc = concat!("`ucdr_deserialize_endian_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid; `value` null or writable.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_deserialize_endian_ $name>](ub: *mut ucdrBuffer, endianness: u32, value: *mut $t) -> bool {
            // SAFETY: contract.
            let Some(ub) = (unsafe { buffer_mut(ub) }) else { return false };
            if value.is_null() {
                ub.error = true;
                return false;
            }
            let Some(v) = read::<$t>(ub, endianness) else { return false };
            // SAFETY: non-null and writable (contract).
            unsafe { value.write(v) };
            true
        }

        #[doc = concat!("`ucdr_serialize_array_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid; `array` holds `size` elements.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_serialize_array_ $name>](ub: *mut ucdrBuffer, array: *const $t, size: usize) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub| { let e = ub.endianness;
                // SAFETY: contract.
                unsafe { write_array(ub, e, array, size) } })
        }

        #[doc = concat!("`ucdr_serialize_endian_array_", stringify!($name), "`.\n\n# Safety\nAs the plain array function.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_serialize_endian_array_ $name>](ub: *mut ucdrBuffer, endianness: u32, array: *const $t, size: usize) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub|
                // SAFETY: contract.
                unsafe { write_array(ub, endianness, array, size) })
        }

        #[doc = concat!("`ucdr_deserialize_array_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid; `array` has room for `size` elements.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_deserialize_array_ $name>](ub: *mut ucdrBuffer, array: *mut $t, size: usize) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub| { let e = ub.endianness;
                // SAFETY: contract.
                unsafe { read_array(ub, e, array, size) } })
        }

        #[doc = concat!("`ucdr_deserialize_endian_array_", stringify!($name), "`.\n\n# Safety\nAs the plain array function.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_deserialize_endian_array_ $name>](ub: *mut ucdrBuffer, endianness: u32, array: *mut $t, size: usize) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub|
                // SAFETY: contract.
                unsafe { read_array(ub, endianness, array, size) })
        }

        #[doc = concat!("`ucdr_serialize_sequence_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid; `array` holds `length` elements.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_serialize_sequence_ $name>](ub: *mut ucdrBuffer, array: *const $t, length: u32) -> bool {
            // SAFETY: contract.
            let e = unsafe { ub.as_ref() }.map_or(BIG, |b| b.endianness);
            // SAFETY: contract.
            unsafe { [<ucdr_serialize_endian_sequence_ $name>](ub, e, array, length) }
        }

        #[doc = concat!("`ucdr_serialize_endian_sequence_", stringify!($name), "`.\n\n# Safety\nAs the plain sequence function.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_serialize_endian_sequence_ $name>](ub: *mut ucdrBuffer, endianness: u32, array: *const $t, length: u32) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub| write(ub, endianness, length)
                // SAFETY: contract.
                && unsafe { write_array(ub, endianness, array, usize::try_from(length).unwrap_or(usize::MAX)) })
        }

        #[doc = concat!("`ucdr_deserialize_sequence_", stringify!($name), "`.\n\n# Safety\n`ub` null or valid; `array` has room for `capacity` elements; `length` null or writable.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_deserialize_sequence_ $name>](ub: *mut ucdrBuffer, array: *mut $t, capacity: usize, length: *mut u32) -> bool {
            // SAFETY: contract.
            let e = unsafe { ub.as_ref() }.map_or(BIG, |b| b.endianness);
            // SAFETY: contract.
            unsafe { [<ucdr_deserialize_endian_sequence_ $name>](ub, e, array, capacity, length) }
        }

        #[doc = concat!("`ucdr_deserialize_endian_sequence_", stringify!($name), "`.\n\n# Safety\nAs the plain sequence function.")]
        #[no_mangle]
        pub unsafe extern "C" fn [<ucdr_deserialize_endian_sequence_ $name>](ub: *mut ucdrBuffer, endianness: u32, array: *mut $t, capacity: usize, length: *mut u32) -> bool {
            // SAFETY: contract.
            unsafe { buffer_mut(ub) }.is_some_and(|ub|
                // SAFETY: contract.
                unsafe { read_sequence(ub, endianness, array, capacity, length) })
        }
    )*}};
}

primitive_functions!(
    bool: bool,
    char: u8,
    int8_t: i8,
    uint8_t: u8,
    int16_t: i16,
    uint16_t: u16,
    int32_t: i32,
    uint32_t: u32,
    int64_t: i64,
    uint64_t: u64,
    float: f32,
    double: f64,
);

/// `ucdr_serialize_string`.
///
/// # Safety
/// `ub` null or valid; `string` null or NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn ucdr_serialize_string(ub: *mut ucdrBuffer, string: *const c_char) -> bool {
    // SAFETY: contract.
    let e = unsafe { ub.as_ref() }.map_or(BIG, |b| b.endianness);
    // SAFETY: contract.
    unsafe { ucdr_serialize_endian_string(ub, e, string) }
}

/// `ucdr_serialize_endian_string`: length with the NUL, the bytes, the NUL. A null string fails.
///
/// # Safety
/// As [`ucdr_serialize_string`].
#[no_mangle]
pub unsafe extern "C" fn ucdr_serialize_endian_string(
    ub: *mut ucdrBuffer,
    endianness: u32,
    string: *const c_char,
) -> bool {
    // SAFETY: contract.
    let Some(ub) = (unsafe { buffer_mut(ub) }) else { return false };
    if string.is_null() {
        ub.error = true;
        return false;
    }
    // SAFETY: non-null and NUL-terminated (contract).
    let bytes = unsafe { CStr::from_ptr(string) }.to_bytes_with_nul();
    let Ok(len) = u32::try_from(bytes.len()) else {
        ub.error = true;
        return false;
    };
    // SAFETY: `bytes` is a live slice of `len` elements.
    write(ub, endianness, len) && unsafe { write_array(ub, endianness, bytes.as_ptr(), bytes.len()) }
}

/// `ucdr_deserialize_string`.
///
/// # Safety
/// `ub` null or valid; `string` has room for `capacity` bytes.
#[no_mangle]
pub unsafe extern "C" fn ucdr_deserialize_string(ub: *mut ucdrBuffer, string: *mut c_char, capacity: usize) -> bool {
    // SAFETY: contract.
    let e = unsafe { ub.as_ref() }.map_or(BIG, |b| b.endianness);
    // SAFETY: contract.
    unsafe { ucdr_deserialize_endian_string(ub, e, string, capacity) }
}

/// `ucdr_deserialize_endian_string`: fails (with `error` set) when the string and its NUL exceed `capacity`.
/// The result is always NUL-terminated on success, even if the sender left the NUL out.
///
/// # Safety
/// As [`ucdr_deserialize_string`].
#[no_mangle]
pub unsafe extern "C" fn ucdr_deserialize_endian_string(
    ub: *mut ucdrBuffer,
    endianness: u32,
    string: *mut c_char,
    capacity: usize,
) -> bool {
    // SAFETY: contract.
    let Some(ub) = (unsafe { buffer_mut(ub) }) else { return false };
    if string.is_null() || capacity == 0 {
        ub.error = true;
        return false;
    }
    let Some(len) = read::<u32>(ub, endianness) else { return false };
    let len = usize::try_from(len).unwrap_or(usize::MAX);
    if len > capacity {
        ub.error = true;
        return false;
    }
    // SAFETY: `string` has room for `capacity >= len` bytes (contract).
    if !unsafe { read_array(ub, endianness, string.cast::<u8>(), len) } {
        return false;
    }
    // SAFETY: `len.max(1) - 1 < capacity`, inside `string`.
    unsafe { string.add(len.max(1) - 1).write(0) };
    true
}
