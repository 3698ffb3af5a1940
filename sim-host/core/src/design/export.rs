//! Conversion of design results (f64) to the flight crate's `f32` static matrices.

use nalgebra::{DMatrix, SMatrix};

/// `Some` when the shape matches and every value is finite in `f32`.
pub fn to_f32<const R: usize, const C: usize>(m: &DMatrix<f64>) -> Option<SMatrix<f32, R, C>> {
    if m.shape() != (R, C) {
        return None;
    }
    let out = SMatrix::<f32, R, C>::from_fn(|r, c| m[(r, c)] as f32);
    out.iter().all(|v| v.is_finite()).then_some(out)
}
