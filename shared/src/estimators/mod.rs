//! Transmittance estimators: Eq. 4 (`transmittance`), Alg. 1 and 2 (their one body over lanes,
//! `wide`, what it reads of a volume, `lane_volume`, and its one-ray form, `optical_depth`), the tracking baselines (`tracking`), Kettunen
//! et al.'s ray marching (`ray_marching`), Misso et al.'s telescoping series (`telescoping`), and the one estimate of a ray segment by any of them
//! (`estimate`).

pub mod estimate;
pub mod inverted_tracking;
pub mod lane_volume;
pub mod optical_depth;
pub mod ray_marching;
pub mod telescoping;
pub mod tracking;
pub mod transmittance;
pub mod wide;
