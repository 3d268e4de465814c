//! Micro-CDR (include/ucdr/microcdr.h): `ucdrBuffer` and the `ucdr_*` functions.

pub mod buffer;
pub mod primitives;
