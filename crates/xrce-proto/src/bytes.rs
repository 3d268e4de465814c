//! Byte copies that cannot panic.
//!
//! `<[u8]>::copy_from_slice` and `copy_within` check their lengths and, on a mismatch, panic with a message
//! that formats the two lengths. In a `panic = "abort"` firmware build that message alone links `core::fmt`'s
//! integer formatting and padding (~3 KB of `.text`, docs/client-footprint.md), although every caller here
//! has checked its lengths already. These copies take what fits instead, with no panic path.

/// Copies `src` to the start of `dst`, as many bytes as both hold; how many that was.
#[inline]
pub fn copy(dst: &mut [u8], src: &[u8]) -> usize {
    let n = dst.len().min(src.len());
    // Indexed on both sides up to one bound: optimised builds make this one `memcpy` (no per-byte bounds
    // checks remain); `opt-level = "z"` keeps the byte loop, a dozen bytes of code. An iterator `zip` would
    // leave its adapters' code behind at that level.
    if let (Some(d), Some(s)) = (dst.get_mut(..n), src.get(..n)) {
        for i in 0..n {
            if let (Some(x), Some(y)) = (d.get_mut(i), s.get(i)) {
                *x = *y;
            }
        }
    }
    n
}

/// Moves the bytes of `buf` in `src` to start at `dest` (the ranges may overlap), as many as both ranges hold
/// inside `buf`; how many that was.
pub fn copy_within(buf: &mut [u8], src: core::ops::Range<usize>, dest: usize) -> usize {
    let end = src.end.min(buf.len());
    let n = end.saturating_sub(src.start).min(buf.len().saturating_sub(dest));
    // Both indices stay below `buf.len()`, so neither sum overflows; forwards when moving down, backwards when
    // moving up, so overlapping bytes are read before they are overwritten.
    let mut move_byte = |i: usize| {
        if let Some(&b) = buf.get(src.start + i) {
            if let Some(slot) = buf.get_mut(dest + i) {
                *slot = b;
            }
        }
    };
    if dest <= src.start {
        (0..n).for_each(&mut move_byte);
    } else {
        (0..n).rev().for_each(&mut move_byte);
    }
    n
}

/// Rotates `buf` left by `mid` bytes (`<[u8]>::rotate_left`) by three reversals; `mid` beyond the length
/// rotates by nothing. `rotate_left` moves the bytes with `memmove`, which on a Cortex-M firmware links
/// compiler-builtins' 1.6 KB implementation for this one use; the reversals swap bytes in place (twice the
/// moves, over histories of a few KiB, on fragment reassembly and stream renumbering only).
pub fn rotate_left(buf: &mut [u8], mid: usize) {
    if mid == 0 || mid >= buf.len() {
        return;
    }
    let len = buf.len();
    reverse(buf, 0, mid);
    reverse(buf, mid, len);
    reverse(buf, 0, len);
}

/// Reverses `buf[lo..hi]` in place. A loop of checked accesses rather than `<[u8]>::reverse` and
/// `split_at_mut`: where they are not inlined their bounds panics link `core::fmt`'s integer printing.
fn reverse(buf: &mut [u8], mut lo: usize, mut hi: usize) {
    while lo + 1 < hi {
        hi -= 1;
        if let (Some(&a), Some(&b)) = (buf.get(lo), buf.get(hi)) {
            if let Some(x) = buf.get_mut(lo) {
                *x = b;
            }
            if let Some(y) = buf.get_mut(hi) {
                *y = a;
            }
        }
        lo += 1;
    }
}

/// Rotates `buf` right by `k` bytes (`<[u8]>::rotate_right`): [`rotate_left`] by the rest.
pub fn rotate_right(buf: &mut [u8], k: usize) {
    if k == 0 || k >= buf.len() {
        return;
    }
    rotate_left(buf, buf.len() - k);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copy_takes_what_fits() {
        let mut dst = [0u8; 3];
        assert_eq!(copy(&mut dst, &[1, 2]), 2);
        assert_eq!(dst, [1, 2, 0]);
        assert_eq!(copy(&mut dst, &[4, 5, 6, 7]), 3);
        assert_eq!(dst, [4, 5, 6]);
    }

    #[test]
    fn copy_within_moves_overlapping_ranges_both_ways() {
        let mut buf = [1u8, 2, 3, 4, 5, 6];
        assert_eq!(copy_within(&mut buf, 2..5, 0), 3);
        assert_eq!(buf, [3, 4, 5, 4, 5, 6]);
        let mut buf = [1u8, 2, 3, 4, 5, 6];
        assert_eq!(copy_within(&mut buf, 0..3, 2), 3);
        assert_eq!(buf, [1, 2, 1, 2, 3, 6]);
    }

    #[test]
    fn copy_within_clips_ranges_outside_the_buffer() {
        let mut buf = [1u8, 2, 3, 4];
        assert_eq!(copy_within(&mut buf, 2..9, 0), 2);
        assert_eq!(buf, [3, 4, 3, 4]);
        assert_eq!(copy_within(&mut buf, 0..4, 3), 1);
        assert_eq!(buf, [3, 4, 3, 3]);
        assert_eq!(copy_within(&mut buf, 7..9, 0), 0);
        let reversed = core::ops::Range { start: 3, end: 1 };
        assert_eq!(copy_within(&mut buf, reversed, 0), 0);
    }

    #[test]
    fn rotations_match_the_slice_methods() {
        for len in 0..9usize {
            for k in 0..=len + 1 {
                let orig: [u8; 8] = [1, 2, 3, 4, 5, 6, 7, 8];
                let mut a = orig;
                let mut b = orig;
                rotate_left(&mut a[..len], k);
                if k < len {
                    b[..len].rotate_left(k);
                }
                assert_eq!(a, b, "left len {len} k {k}");
                let (mut a, mut b) = (orig, orig);
                rotate_right(&mut a[..len], k);
                if k < len {
                    b[..len].rotate_right(k);
                }
                assert_eq!(a, b, "right len {len} k {k}");
            }
        }
    }
}
