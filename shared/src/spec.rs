//! Specialization constants: the value that leaves a field as the buffer holds it.

/// The value of a kernel's specialization constant that keeps the field of its buffer (the
/// constants' default: a pipeline built without specialization runs every variant).
pub const UNSPECIALIZED: u32 = u32::MAX;

/// A field's value in a pipeline: the specialization constant `spec`, or the buffer's `field`
/// where it is [`UNSPECIALIZED`].
#[inline]
pub fn or_keep(spec: u32, field: u32) -> u32 {
    if spec != UNSPECIALIZED {
        spec
    } else {
        field
    }
}
