//! `--shade interpolate` (Wang et al. 2009, section 3.4): indirect light is computed only at each
//! shading-point cluster's sample point s_j and interpolated to every shading point x from the
//! sample points of its F nearest clusters with the irradiance-caching weight
//!
//! ```text
//!   w(s_j) = 1 / ( |x − s_j| / R_j + √(2 − 2 n(x)·n(s_j)) )
//!   L(x)   = Σ_j w(s_j) L(s_j) / Σ_j w(s_j)
//! ```
//!
//! R_j is the harmonic mean distance from s_j to the surfaces it sees, measured with gather rays
//! (a stage of its own). Both backends keep 1 / R_j, the mean of 1 / t over the rays (a ray that
//! escapes counts 1 / ∞ = 0): a sample point that sees nothing near has 1 / R_j = 0 and is
//! weighted by its normal alone, with no infinity anywhere.

/// The smallest error the weight divides by: a shading point at its own sample point with the
/// same normal has error 0, and its weight 1 / MIN_ERROR = 10⁴ makes it take its own sample's
/// value to within a part in 10⁴ of the typical neighbour's share, instead of dividing by zero.
pub const MIN_ERROR: f32 = 1e-4;

/// Gather rays per sample point unless `--gather-rays` says otherwise: 1 / R_j from 16 cosine
/// rays has a relative standard error of about a third in a box, enough for a weight whose
/// position term only has to fall off at the right scale.
pub const DEFAULT_GATHER_RAYS: u32 = 16;

/// Most gather rays per sample point.
pub const MAX_GATHER_RAYS: u32 = 4096;

/// The parameters of the gather rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GatherParams {
    pub seed: u32,
    /// Cosine-distributed rays per sample point; ray r of point j draws two numbers from stream
    /// (seed, `Stream::Gather`, j) in ray order.
    pub rays: u32,
}

/// The weight of a sample point at squared distance `d2` from the shading point, whose normal
/// makes cosine `cos` with the shading point's, and whose harmonic mean distance is 1 / `inv_r`
/// (Wang et al.'s weight, the formula above). Both backends evaluate exactly these operations.
#[inline]
pub fn weight(d2: f32, cos: f32, inv_r: f32) -> f32 {
    let error = d2.sqrt() * inv_r + (2.0 - 2.0 * cos).max(0.0).sqrt();
    1.0 / error.max(MIN_ERROR)
}

/// 1 / R_j from the sum of 1 / t over `rays` gather rays (escaped rays add nothing).
#[inline]
pub fn inverse_radius(sum_inv_t: f32, rays: u32) -> f32 {
    sum_inv_t / rays.max(1) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_by_hand() {
        // 3 units away from a sample whose harmonic mean distance is 2, same normal:
        // error 3 / 2 + 0 = 1.5, weight 2 / 3.
        assert!((weight(9.0, 1.0, 0.5) - 2.0 / 3.0).abs() < 1e-7);
        // At the sample point with the normal turned by 90 degrees: error √2.
        assert!((weight(0.0, 0.0, 0.5) - 1.0 / 2f32.sqrt()).abs() < 1e-7);
        // Both: 1 unit at R = 4 (0.25) and a normal turned by 60 degrees (cos 0.5, √1 = 1).
        assert!((weight(1.0, 0.5, 0.25) - 0.8).abs() < 1e-7);
        // Opposite normals: √4 = 2 whatever the distance to a sample that sees nothing near.
        assert!((weight(1e6, -1.0, 0.0) - 0.5).abs() < 1e-7);
        // The point itself: the floor, not infinity.
        assert_eq!(weight(0.0, 1.0, 3.0), 1.0 / MIN_ERROR);
        // A cosine a rounding above 1 does not make a NaN.
        assert_eq!(weight(0.0, 1.0 + 1e-7, 1.0), 1.0 / MIN_ERROR);
    }

    #[test]
    fn the_harmonic_mean_of_distances() {
        // Rays at distances 1, 2 and 4 and one escaped: (1 + 1/2 + 1/4 + 0) / 4.
        assert_eq!(inverse_radius(1.0 + 0.5 + 0.25, 4), 0.4375);
        assert_eq!(inverse_radius(0.0, 16), 0.0);
    }
}
