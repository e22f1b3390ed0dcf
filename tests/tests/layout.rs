//! Pins the byte layout of every struct shared between host, kernels and CPU backend.

use shared::launch::Launch;
use shared::probe::{DepthPair, MathValues, RngDraws, TransmittancePair};
use shared::rng::Pcg32;
use shared::Complex;
use std::mem::{align_of, size_of};

#[test]
fn shared_struct_layouts() {
    assert_eq!(size_of::<Launch>(), 16);
    assert_eq!(size_of::<DepthPair>(), 8);
    assert_eq!(size_of::<TransmittancePair>(), 8);
    assert_eq!(size_of::<MathValues>(), 16);
    assert_eq!(size_of::<RngDraws>(), 32);
    assert_eq!(size_of::<Pcg32>(), 16);
    assert_eq!(align_of::<Pcg32>(), 8);
    assert_eq!(size_of::<Complex>(), 8);
}
