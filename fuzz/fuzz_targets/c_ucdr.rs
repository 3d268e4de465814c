//! The C library's Micro-CDR (`ucdr_*`, called through its exported `extern "C"` functions, under
//! AddressSanitizer as cargo-fuzz builds it) on an arbitrary buffer of arbitrary size, origin, offset and
//! endianness: any sequence of reads, writes, alignments, advances and resets must stay inside the buffer
//! (ASan reports the first byte outside), report lengths no greater than the buffer, and set `error` rather
//! than overrun. Every output array sits in its own heap allocation of exactly its capacity, so an
//! overrun of it is caught too.
#![no_main]

use arbitrary::Arbitrary;
use core::ffi::c_char;
use libfuzzer_sys::fuzz_target;
use microxrcedds_client::ucdr::buffer::*;
use microxrcedds_client::ucdr::primitives::*;

#[derive(Arbitrary, Debug)]
enum Op {
    ReadPrimitive { kind: u8, endian: Option<u32> },
    WritePrimitive { kind: u8, endian: Option<u32>, value: u64 },
    ReadArray { kind: u8, size: u8 },
    WriteArray { kind: u8, size: u8 },
    ReadSequence { kind: u8, capacity: u8 },
    WriteSequence { kind: u8, length: u8 },
    ReadString { capacity: u8 },
    WriteString(Vec<u8>),
    Align(u8),
    Advance(u16),
    Reset,
    ResetOffset(u16),
    Copy,
}

#[derive(Arbitrary, Debug)]
struct Input {
    origin: u8,
    offset: u8,
    endianness: u32,
    bytes: Vec<u8>,
    ops: Vec<Op>,
}

fuzz_target!(|input: Input| {
    let Input { origin, offset, endianness, bytes, ops } = input;
    // The buffer in its own allocation of exactly its length.
    let mut memory = bytes.into_boxed_slice();
    let size = memory.len();
    let mut ub = ucdrBuffer::over(core::ptr::null_mut(), 0, 0, 0, 0);
    // SAFETY: `memory` outlives every call below and is `size` bytes long.
    unsafe {
        ucdr_init_buffer_origin_offset_endian(
            &mut ub,
            memory.as_mut_ptr(),
            size,
            usize::from(origin),
            usize::from(origin) + usize::from(offset),
            endianness % 2,
        )
    };
    for op in ops.iter().take(64) {
        // SAFETY: `ub` is initialised over `memory`; every pointer passed is valid for the size given.
        unsafe { apply(&mut ub, op) };
        // SAFETY: as above.
        let (length, remaining) = unsafe { (ucdr_buffer_length(&ub), ucdr_buffer_remaining(&ub)) };
        assert!(length <= size && remaining <= size && length + remaining == size, "{length} + {remaining} != {size}");
    }
});

/// One operation; output arrays are heap allocations of exactly their capacity.
///
/// # Safety
/// `ub` initialised over live memory.
unsafe fn apply(ub: &mut ucdrBuffer, op: &Op) {
    macro_rules! primitives {
        ($kind:expr, $do:ident) => {
            match $kind % 12 {
                0 => $do!(bool, false),
                1 => $do!(char, 0u8),
                2 => $do!(int8_t, 0i8),
                3 => $do!(uint8_t, 0u8),
                4 => $do!(int16_t, 0i16),
                5 => $do!(uint16_t, 0u16),
                6 => $do!(int32_t, 0i32),
                7 => $do!(uint32_t, 0u32),
                8 => $do!(int64_t, 0i64),
                9 => $do!(uint64_t, 0u64),
                10 => $do!(float, 0f32),
                _ => $do!(double, 0f64),
            }
        };
    }
    // SAFETY (for every call below): `ub` is valid (contract), outputs are writable for the sizes given,
    // inputs readable for theirs.
    unsafe {
        match op {
            Op::ReadPrimitive { kind, endian } => {
                macro_rules! read {
                    ($n:ident, $zero:expr) => {{
                        let mut v = Box::new($zero);
                        match endian {
                            Some(e) => pastey::paste!([<ucdr_deserialize_endian_ $n>](ub, e % 2, &mut *v)),
                            None => pastey::paste!([<ucdr_deserialize_ $n>](ub, &mut *v)),
                        };
                    }};
                }
                primitives!(kind, read);
            }
            Op::WritePrimitive { kind, endian, value } => {
                macro_rules! write {
                    ($n:ident, $zero:expr) => {{
                        let v = from_bits($zero, *value);
                        match endian {
                            Some(e) => pastey::paste!([<ucdr_serialize_endian_ $n>](ub, e % 2, v)),
                            None => pastey::paste!([<ucdr_serialize_ $n>](ub, v)),
                        };
                    }};
                }
                primitives!(kind, write);
            }
            Op::ReadArray { kind, size } => {
                macro_rules! read_array {
                    ($n:ident, $zero:expr) => {{
                        let mut v = vec![$zero; usize::from(*size)].into_boxed_slice();
                        pastey::paste!([<ucdr_deserialize_array_ $n>](ub, v.as_mut_ptr(), v.len()));
                    }};
                }
                primitives!(kind, read_array);
            }
            Op::WriteArray { kind, size } => {
                macro_rules! write_array {
                    ($n:ident, $zero:expr) => {{
                        let v = vec![$zero; usize::from(*size)].into_boxed_slice();
                        pastey::paste!([<ucdr_serialize_array_ $n>](ub, v.as_ptr(), v.len()));
                    }};
                }
                primitives!(kind, write_array);
            }
            Op::ReadSequence { kind, capacity } => {
                macro_rules! read_sequence {
                    ($n:ident, $zero:expr) => {{
                        let mut v = vec![$zero; usize::from(*capacity)].into_boxed_slice();
                        let mut length = 0u32;
                        if pastey::paste!([<ucdr_deserialize_sequence_ $n>](ub, v.as_mut_ptr(), v.len(), &mut length)) {
                            assert!(length as usize <= v.len(), "a sequence longer than its capacity was accepted");
                        }
                    }};
                }
                primitives!(kind, read_sequence);
            }
            Op::WriteSequence { kind, length } => {
                macro_rules! write_sequence {
                    ($n:ident, $zero:expr) => {{
                        let v = vec![$zero; usize::from(*length)].into_boxed_slice();
                        pastey::paste!([<ucdr_serialize_sequence_ $n>](ub, v.as_ptr(), u32::from(*length)));
                    }};
                }
                primitives!(kind, write_sequence);
            }
            Op::ReadString { capacity } => {
                let mut s = vec![0x55 as c_char; usize::from(*capacity)].into_boxed_slice();
                if ucdr_deserialize_string(ub, s.as_mut_ptr(), s.len()) {
                    assert!(s.contains(&0), "a string was accepted without its NUL in the capacity");
                }
            }
            Op::WriteString(text) => {
                let mut s: Vec<c_char> = text.iter().filter(|&&b| b != 0).map(|&b| b as c_char).collect();
                s.push(0);
                let s = s.into_boxed_slice();
                ucdr_serialize_string(ub, s.as_ptr());
            }
            Op::Align(n) => ucdr_align_to(ub, usize::from(*n)),
            Op::Advance(n) => ucdr_advance_buffer(ub, usize::from(*n)),
            Op::Reset => ucdr_reset_buffer(ub),
            Op::ResetOffset(n) => ucdr_reset_buffer_offset(ub, usize::from(*n)),
            Op::Copy => {
                let mut copy = *ub;
                ucdr_copy_buffer(&mut copy, ub);
                *ub = copy;
            }
        }
    }
}

/// A value of `T` from arbitrary bits.
fn from_bits<T: FromBits>(_: T, bits: u64) -> T {
    T::from_bits(bits)
}

trait FromBits {
    fn from_bits(bits: u64) -> Self;
}

macro_rules! from_bits_as {
    ($($t:ty),*) => {$(impl FromBits for $t { fn from_bits(bits: u64) -> Self { bits as $t } })*};
}
from_bits_as!(u8, i8, u16, i16, u32, i32, u64, i64);

impl FromBits for bool {
    fn from_bits(bits: u64) -> Self {
        bits & 1 != 0
    }
}
impl FromBits for f32 {
    fn from_bits(bits: u64) -> Self {
        f32::from_bits(bits as u32)
    }
}
impl FromBits for f64 {
    fn from_bits(bits: u64) -> Self {
        f64::from_bits(bits)
    }
}
