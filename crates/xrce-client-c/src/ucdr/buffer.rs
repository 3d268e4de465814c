//! `ucdrBuffer` and the functions that set it up and report its state.

use core::ffi::c_void;

/// `ucdrEndianness` value of big-endian data.
pub const BIG: u32 = 0;
/// `ucdrEndianness` value of little-endian data.
pub const LITTLE: u32 = 1;
/// The machine's `ucdrEndianness`.
pub const MACHINE: u32 = if cfg!(target_endian = "big") { BIG } else { LITTLE };

/// `OnFullBuffer`: returns `false` once the buffer has room again, `true` to give up.
pub type OnFullBuffer = Option<unsafe extern "C" fn(ub: *mut ucdrBuffer, args: *mut c_void) -> bool>;

/// `ucdrBuffer` (include/ucdr/microcdr.h, same fields in the same order).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct ucdrBuffer {
    /// First byte of the memory.
    pub init: *mut u8,
    /// One past its last byte.
    pub final_: *mut u8,
    /// Next byte to read or write.
    pub iterator: *mut u8,
    /// Offset of `init` in the whole serialized stream.
    pub origin: usize,
    /// Offset of `iterator` in the whole serialized stream (alignment counts from it).
    pub offset: usize,
    /// `ucdrEndianness`.
    pub endianness: u32,
    /// Size of the last primitive moved.
    pub last_data_size: u8,
    /// Set by any operation that did not fit.
    pub error: bool,
    /// Asked for more room when a value does not fit.
    pub on_full_buffer: OnFullBuffer,
    /// Argument of `on_full_buffer`.
    pub args: *mut c_void,
}

impl ucdrBuffer {
    /// A buffer over `size` bytes at `data`, `offset` bytes into a stream whose first byte is at `origin`.
    pub fn over(data: *mut u8, size: usize, origin: usize, offset: usize, endianness: u32) -> Self {
        let skip = offset.saturating_sub(origin).min(size);
        Self {
            init: data,
            final_: data.wrapping_add(size),
            iterator: data.wrapping_add(skip),
            origin,
            offset: origin + skip,
            endianness,
            last_data_size: 0,
            error: false,
            on_full_buffer: None,
            args: core::ptr::null_mut(),
        }
    }

    /// Bytes left between the iterator and the end (0 for an inconsistent buffer).
    pub fn remaining(&self) -> usize {
        if self.iterator < self.init {
            return 0;
        }
        (self.final_ as usize).saturating_sub(self.iterator as usize)
    }

    /// Makes room for `n` bytes aligned to `align` (a power of two, or 0) and moves past them: where they start, or
    /// `None` (and `error` set) when they do not fit and `on_full_buffer` cannot make room.
    pub fn take(&mut self, align: usize, n: usize) -> Option<*mut u8> {
        if self.error {
            return None;
        }
        let mut asked_for_room = false;
        loop {
            // `align` is a power of two here (1, 2, 4, 8): a mask, no division.
            let pad = self.offset.wrapping_neg() & align.saturating_sub(1);
            if pad + n <= self.remaining() {
                self.iterator = self.iterator.wrapping_add(pad);
                let at = self.iterator;
                self.iterator = self.iterator.wrapping_add(n);
                self.offset += pad + n;
                self.last_data_size = u8::try_from(n).unwrap_or(u8::MAX);
                return Some(at);
            }
            let Some(on_full) = self.on_full_buffer.filter(|_| !asked_for_room) else { break };
            asked_for_room = true;
            let this: *mut Self = self;
            // SAFETY: the callback was installed by the C program for this buffer and receives it as it was
            // handed over; nothing in Rust borrows the buffer across the call but through `this`.
            if unsafe { on_full(this, self.args) } {
                break;
            }
        }
        // One failure path for both ways out (firmware size).
        self.error = true;
        None
    }
}

/// Padding that brings `offset` to a multiple of `align` (0 for `align` 0 or 1).
pub const fn alignment(offset: usize, align: usize) -> usize {
    if align <= 1 {
        return 0;
    }
    (align - offset % align) % align
}

/// The buffer behind a C pointer, `None` for null.
///
/// # Safety
/// `ub` is null or points to a `ucdrBuffer` the caller may change, not borrowed elsewhere.
pub unsafe fn buffer_mut<'b>(ub: *mut ucdrBuffer) -> Option<&'b mut ucdrBuffer> {
    // SAFETY: as the caller guarantees.
    unsafe { ub.as_mut() }
}

/// Read-only [`buffer_mut`].
///
/// # Safety
/// `ub` is null or points to a readable `ucdrBuffer`.
unsafe fn buffer_ref<'b>(ub: *const ucdrBuffer) -> Option<&'b ucdrBuffer> {
    // SAFETY: as the caller guarantees.
    unsafe { ub.as_ref() }
}

/// `ucdr_init_buffer`.
///
/// # Safety
/// `ub` is null or writable; `data` holds `size` bytes for as long as the buffer is used.
#[no_mangle]
pub unsafe extern "C" fn ucdr_init_buffer(ub: *mut ucdrBuffer, data: *mut u8, size: usize) {
    // SAFETY: forwarded contract.
    unsafe { ucdr_init_buffer_origin_offset_endian(ub, data, size, 0, 0, MACHINE) }
}

/// `ucdr_init_buffer_origin`.
///
/// # Safety
/// As [`ucdr_init_buffer`].
#[no_mangle]
pub unsafe extern "C" fn ucdr_init_buffer_origin(ub: *mut ucdrBuffer, data: *mut u8, size: usize, origin: usize) {
    // SAFETY: forwarded contract.
    unsafe { ucdr_init_buffer_origin_offset_endian(ub, data, size, origin, origin, MACHINE) }
}

/// `ucdr_init_buffer_origin_offset`.
///
/// # Safety
/// As [`ucdr_init_buffer`].
#[no_mangle]
pub unsafe extern "C" fn ucdr_init_buffer_origin_offset(
    ub: *mut ucdrBuffer,
    data: *mut u8,
    size: usize,
    origin: usize,
    offset: usize,
) {
    // SAFETY: forwarded contract.
    unsafe { ucdr_init_buffer_origin_offset_endian(ub, data, size, origin, offset, MACHINE) }
}

/// `ucdr_init_buffer_origin_offset_endian`. A null `data` gives an empty buffer.
///
/// # Safety
/// As [`ucdr_init_buffer`].
#[no_mangle]
pub unsafe extern "C" fn ucdr_init_buffer_origin_offset_endian(
    ub: *mut ucdrBuffer,
    data: *mut u8,
    size: usize,
    origin: usize,
    offset: usize,
    endianness: u32,
) {
    if ub.is_null() {
        return;
    }
    let size = if data.is_null() { 0 } else { size };
    // SAFETY: `ub` is non-null and writable (contract); `write` does not read the uninitialised old value.
    unsafe { ub.write(ucdrBuffer::over(data, size, origin, offset, endianness)) }
}

/// `ucdr_copy_buffer`.
///
/// # Safety
/// Both null or valid buffers.
#[no_mangle]
pub unsafe extern "C" fn ucdr_copy_buffer(dest: *mut ucdrBuffer, source: *const ucdrBuffer) {
    if dest.is_null() {
        return;
    }
    // SAFETY: contract.
    if let Some(source) = unsafe { buffer_ref(source) } {
        // SAFETY: `dest` is non-null and writable (contract).
        unsafe { dest.write(*source) }
    }
}

/// `ucdr_set_on_full_buffer_callback`.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_set_on_full_buffer_callback(
    ub: *mut ucdrBuffer,
    on_full: OnFullBuffer,
    args: *mut c_void,
) {
    // SAFETY: contract.
    if let Some(ub) = unsafe { buffer_mut(ub) } {
        ub.on_full_buffer = on_full;
        ub.args = args;
    }
}

/// `ucdr_reset_buffer`: back to the start, error cleared.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_reset_buffer(ub: *mut ucdrBuffer) {
    // SAFETY: contract.
    if let Some(b) = unsafe { buffer_ref(ub) } {
        let origin = b.origin;
        // SAFETY: contract.
        unsafe { ucdr_reset_buffer_offset(ub, origin) }
    }
}

/// `ucdr_reset_buffer_offset`: to `offset` of the stream, error cleared.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_reset_buffer_offset(ub: *mut ucdrBuffer, offset: usize) {
    // SAFETY: contract.
    if let Some(ub) = unsafe { buffer_mut(ub) } {
        let size = (ub.final_ as usize).saturating_sub(ub.init as usize);
        let fresh = ucdrBuffer::over(ub.init, size, ub.origin, offset, ub.endianness);
        *ub = ucdrBuffer { on_full_buffer: ub.on_full_buffer, args: ub.args, ..fresh };
    }
}

/// `ucdr_align_to`: skips the padding before a value of `size` bytes.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_align_to(ub: *mut ucdrBuffer, size: usize) {
    // SAFETY: contract.
    if let Some(ub) = unsafe { buffer_mut(ub) } {
        let pad = alignment(ub.offset, size).min(ub.remaining());
        ub.iterator = ub.iterator.wrapping_add(pad);
        ub.offset += pad;
    }
}

/// `ucdr_alignment`: padding before a value of `data_size` bytes at `current_alignment`.
#[no_mangle]
pub extern "C" fn ucdr_alignment(current_alignment: usize, data_size: usize) -> usize {
    alignment(current_alignment, data_size)
}

/// `ucdr_buffer_alignment`: padding before a value of `data_size` bytes at the iterator.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_buffer_alignment(ub: *const ucdrBuffer, data_size: usize) -> usize {
    // SAFETY: contract.
    unsafe { buffer_ref(ub) }.map_or(0, |ub| alignment(ub.offset, data_size))
}

/// `ucdr_advance_buffer`: skips `size` bytes (left as they are); the buffer's `error` is set when they do not
/// fit.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_advance_buffer(ub: *mut ucdrBuffer, size: usize) {
    // SAFETY: contract.
    if let Some(ub) = unsafe { buffer_mut(ub) } {
        let _ = ub.take(1, size);
    }
}

/// `ucdr_buffer_size`: bytes of memory.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_buffer_size(ub: *const ucdrBuffer) -> usize {
    // SAFETY: contract.
    unsafe { buffer_ref(ub) }.map_or(0, |ub| (ub.final_ as usize).saturating_sub(ub.init as usize))
}

/// `ucdr_buffer_length`: bytes used (iterator minus start).
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_buffer_length(ub: *const ucdrBuffer) -> usize {
    // SAFETY: contract.
    unsafe { buffer_ref(ub) }.map_or(0, |ub| (ub.iterator as usize).saturating_sub(ub.init as usize))
}

/// `ucdr_buffer_remaining`: bytes left.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_buffer_remaining(ub: *const ucdrBuffer) -> usize {
    // SAFETY: contract.
    unsafe { buffer_ref(ub) }.map_or(0, ucdrBuffer::remaining)
}

/// `ucdr_buffer_endianness`.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_buffer_endianness(ub: *const ucdrBuffer) -> u32 {
    // SAFETY: contract.
    unsafe { buffer_ref(ub) }.map_or(MACHINE, |ub| ub.endianness)
}

/// `ucdr_buffer_has_error`: `true` for a null buffer too.
///
/// # Safety
/// `ub` null or valid.
#[no_mangle]
pub unsafe extern "C" fn ucdr_buffer_has_error(ub: *const ucdrBuffer) -> bool {
    // SAFETY: contract.
    unsafe { buffer_ref(ub) }.is_none_or(|ub| ub.error)
}
