//! Warps from uniform numbers in [0, 1)² to directions and points.
//!
//! Each warp is a few lines of arithmetic that the WGSL twin transcribes with the same operation
//! order. Their distributions are checked with χ² tests in the CPU crate.

use glam::Vec3;
use std::f32::consts::PI;

/// An orthonormal basis (t, b, n) around a unit vector `n`, branch-light construction of
/// Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT 2017).
#[inline]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

/// Cosine-weighted direction around the unit normal `n`; pdf = cos(theta) / pi.
#[inline]
pub fn cosine_hemisphere(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = orthonormal_basis(n);
    let z = (1.0 - u1).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}

/// Uniform direction on the unit sphere; pdf = 1 / (4 pi).
#[inline]
pub fn uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The cosine to the axis of [`uniform_cone`]'s direction for the same `u1`.
#[inline]
pub fn uniform_cone_cos(cos_max: f32, u1: f32) -> f32 {
    1.0 - u1 * (1.0 - cos_max)
}

/// Uniform direction inside the cone of half-angle acos(`cos_max`) around the unit axis;
/// pdf = 1 / (2 pi (1 - cos_max)).
#[inline]
pub fn uniform_cone(axis: Vec3, cos_max: f32, u1: f32, u2: f32) -> Vec3 {
    let cos_t = uniform_cone_cos(cos_max, u1);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = orthonormal_basis(axis);
    (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + axis * cos_t).normalize()
}

/// Barycentric coordinates (b1, b2) of a uniformly distributed point on a triangle
/// (the square-root parameterisation); the point is `v0 + b1 (v1 - v0) + b2 (v2 - v0)`.
#[inline]
pub fn uniform_triangle(u1: f32, u2: f32) -> (f32, f32) {
    let s = u1.sqrt();
    (s * (1.0 - u2), s * u2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal_for_awkward_normals() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.0, 0.0, -0.99999).normalize(), Vec3::new(1.0, 2.0, -3.0).normalize()] {
            let (t, b) = orthonormal_basis(n);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!(t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5 && t.dot(b).abs() < 1e-5);
        }
    }

    #[test]
    fn warps_stay_in_their_domains() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for i in 0..64 {
            for j in 0..64 {
                let (u1, u2) = (i as f32 / 64.0, j as f32 / 64.0);
                assert!(cosine_hemisphere(n, u1, u2).dot(n) >= -1e-6);
                assert!((uniform_sphere(u1, u2).length() - 1.0).abs() < 1e-5);
                assert!(uniform_cone(n, 0.8, u1, u2).dot(n) >= 0.8 - 1e-5);
                let (b1, b2) = uniform_triangle(u1, u2);
                assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 + 1e-6);
            }
        }
    }

    /// χ² goodness of fit of the cosine-weighted hemisphere sampler: 10 bins in cos θ times 8 in
    /// φ, expected counts from integrating the pdf cos θ / π over each bin,
    /// (Δφ / 2π) (cos_hi² − cos_lo²), in the local frame of an arbitrary normal.
    #[test]
    fn cosine_hemisphere_chi2() {
        use crate::{Rng, Stream};
        let n = Vec3::new(-0.3, 0.4, 0.866).normalize();
        let (t, b) = orthonormal_basis(n);
        let (nc, nphi) = (10usize, 8usize);
        let mut counts = vec![0u32; nc * nphi];
        let samples = 200_000;
        let mut rng = Rng::new(3, Stream::Oracle, 0);
        for _ in 0..samples {
            let d = cosine_hemisphere(n, rng.next_f32(), rng.next_f32());
            let c = d.dot(n).clamp(0.0, 0.999_999);
            let phi = d.dot(b).atan2(d.dot(t)).rem_euclid(2.0 * PI);
            let i = ((c * nc as f32) as usize).min(nc - 1);
            let j = ((phi / (2.0 * PI) * nphi as f32) as usize).min(nphi - 1);
            counts[i * nphi + j] += 1;
        }
        let mut chi2 = 0.0f64;
        for i in 0..nc {
            let (lo, hi) = (i as f64 / nc as f64, (i + 1) as f64 / nc as f64);
            let expected = samples as f64 * (hi * hi - lo * lo) / nphi as f64;
            for j in 0..nphi {
                chi2 += (counts[i * nphi + j] as f64 - expected).powi(2) / expected;
            }
        }
        // 79 degrees of freedom: the 0.999 quantile is 124.8.
        println!("cosine hemisphere: chi2 = {chi2:.1} (79 dof, reject above 124.8)");
        assert!(chi2 < 124.8, "chi2 = {chi2}");
    }
}
