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

/// Point `j` of the first five dimensions of Sobol's sequence, as 32-bit binary fractions.
///
/// Each dimension XORs one direction number per set bit of `j` (the digits of `j` directly, not
/// its Gray code: the first 2^m points are the same set, in another order). Direction numbers are
/// v_k = m_k 2^(32-k) for bit k-1, with m_k from the primitive polynomials and initial numbers of
/// the first entries of Joe and Kuo's table: dimension 1 is van der Corput's (m_k = 1);
/// dimension 2 uses x + 1 (m_k = 2 m_{k-1} xor m_{k-1}, m_1 = 1); dimension 3 uses x^2 + x + 1
/// (m_k = 2 m_{k-1} xor 4 m_{k-2} xor m_{k-2}; 1, 3); dimension 4 uses x^3 + x + 1
/// (m_k = 4 m_{k-2} xor 8 m_{k-3} xor m_{k-3}; 1, 3, 1); dimension 5 uses x^3 + x^2 + 1
/// (m_k = 2 m_{k-1} xor 8 m_{k-3} xor m_{k-3}; 1, 1, 1). Any 2^m consecutive-from-zero points put
/// exactly one point in each interval of length 2^-m of every dimension, and dimensions 1 and 2
/// form a (0, 2)-sequence: one point in each elementary rectangle of area 2^-m. Integer
/// operations only, so the WGSL twin gives the same bits.
#[inline]
pub fn sobol5(j: u32) -> [u32; 5] {
    let mut x = [0u32; 5];
    // m_k of dimensions 2 and 3, and m_{k-1}, m_{k-2}, m_{k-3} of dimensions 3 to 5.
    let mut m2 = 1u32;
    let (mut h3, mut h4, mut h5) = ([0u32; 3], [0u32; 3], [0u32; 3]);
    let mut k = 1u32;
    while k <= 32 && (j >> (k - 1)) != 0 {
        if k >= 2 {
            m2 ^= m2 << 1;
        }
        let m3 = match k {
            1 => 1,
            2 => 3,
            _ => (h3[0] << 1) ^ (h3[1] << 2) ^ h3[1],
        };
        let m4 = match k {
            1 | 3 => 1,
            2 => 3,
            _ => (h4[1] << 2) ^ (h4[2] << 3) ^ h4[2],
        };
        let m5 = match k {
            1..=3 => 1,
            _ => (h5[0] << 1) ^ (h5[2] << 3) ^ h5[2],
        };
        h3 = [m3, h3[0], h3[1]];
        h4 = [m4, h4[0], h4[1]];
        h5 = [m5, h5[0], h5[1]];
        if (j >> (k - 1)) & 1 == 1 {
            let shift = 32 - k;
            x[0] ^= 1 << shift;
            x[1] ^= m2 << shift;
            x[2] ^= m3 << shift;
            x[3] ^= m4 << shift;
            x[4] ^= m5 << shift;
        }
        k += 1;
    }
    x
}

/// The first three dimensions of [`sobol5`].
#[inline]
pub fn sobol3(j: u32) -> [u32; 3] {
    let s = sobol5(j);
    [s[0], s[1], s[2]]
}

/// Sample `j` of a Sobol' set in [0, 1)^5 digitally shifted by `scramble`, as floats from the top
/// 24 bits (see [`scrambled_sobol3`]).
#[inline]
pub fn scrambled_sobol5(j: u32, scramble: [u32; 5]) -> [f32; 5] {
    let s = sobol5(j);
    std::array::from_fn(|d| ((s[d] ^ scramble[d]) >> 8) as f32 * (1.0 / 16_777_216.0))
}

/// Sample `j` of a randomly scrambled Sobol' set in [0, 1)^3: `sobol3(j)` XOR `scramble` (a random
/// digital shift, one per set of samples, which keeps the stratification and makes every sample
/// uniformly distributed, so estimates stay unbiased), as floats from the top 24 bits.
#[inline]
pub fn scrambled_sobol3(j: u32, scramble: [u32; 3]) -> [f32; 3] {
    let s = sobol3(j);
    std::array::from_fn(|d| ((s[d] ^ scramble[d]) >> 8) as f32 * (1.0 / 16_777_216.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against points computed by hand from the direction numbers (bits of j: v_1 for bit 0,
    /// v_2 for bit 1, ...; dimension 2: 1/2, 3/4, 5/8; dimension 3: 1/2, 3/4, 3/8; j = 7 XORs
    /// all three).
    #[test]
    fn sobol3_matches_hand_computed_points() {
        let f = |j: u32| sobol3(j).map(|x| x as f64 / 4_294_967_296.0);
        assert_eq!(f(0), [0.0, 0.0, 0.0]);
        assert_eq!(f(1), [0.5, 0.5, 0.5]);
        assert_eq!(f(2), [0.25, 0.75, 0.75]);
        assert_eq!(f(3), [0.75, 0.25, 0.25]);
        assert_eq!(f(4), [0.125, 0.625, 0.375]);
        assert_eq!(f(7), [0.875, 0.875, 0.125]);
        // Dimensions 4 and 5: v = (1/2, 3/4, 1/8) and (1/2, 1/4, 1/8).
        let g = |j: u32| sobol5(j).map(|x| x as f64 / 4_294_967_296.0);
        assert_eq!(g(1)[3..], [0.5, 0.5]);
        assert_eq!(g(2)[3..], [0.75, 0.25]);
        assert_eq!(g(3)[3..], [0.25, 0.75]);
        assert_eq!(g(4)[3..], [0.125, 0.125]);
        assert_eq!(g(7)[3..], [0.375, 0.875]);
        // k = 4 uses the recurrences: dimension 4: m_4 = 4 m_2 ^ 8 m_1 ^ m_1 = 12 ^ 8 ^ 1 = 5;
        // dimension 5: m_4 = 2 m_3 ^ 8 m_1 ^ m_1 = 2 ^ 8 ^ 1 = 11.
        assert_eq!(g(8)[3..], [5.0 / 16.0, 11.0 / 16.0]);
    }

    /// Independent of the recurrences, and on indices with high bits set, where a loop that stopped
    /// early would drop digits (light particles index past 2^16): dimension 1 is j's bits
    /// reversed (van der Corput), and dimension 2's generator matrix is Pascal's triangle mod 2,
    /// so digit d of the fraction XORs every bit c of j with C(c, d) odd, which by Lucas's
    /// theorem is c & d == d.
    #[test]
    fn sobols_first_two_dimensions_match_their_closed_forms() {
        let pascal = |j: u32| {
            (0..32u32).fold(0u32, |x, d| {
                let parity =
                    (d..32).filter(|&c| c & d == d && (j >> c) & 1 == 1).count() as u32 & 1;
                x | parity << (31 - d)
            })
        };
        let mut rng = crate::rng::Rng::new(17, crate::rng::Stream::Direct, 0);
        let edges = [1, 1 << 16, 3 << 16, 1 << 31, 0x8000_0001, u32::MAX];
        for j in edges.into_iter().chain((0..2000).map(|_| rng.next_u32())) {
            let s = sobol5(j);
            assert_eq!(s[0], j.reverse_bits(), "dimension 1 of point {j:#x}");
            assert_eq!(s[1], pascal(j), "dimension 2 of point {j:#x}");
        }
    }

    /// The stratification direct light and light particles rely on, for every power of two up to
    /// 2^10: each dimension has one point per interval of 2^-m, and dimensions 1-2 one point per
    /// elementary rectangle (a (0, m, 2)-net).
    #[test]
    fn sobol_prefixes_are_stratified() {
        for m in 0..=10u32 {
            let n = 1u32 << m;
            let pts: Vec<[u32; 5]> = (0..n).map(sobol5).collect();
            for d in 0..5 {
                let mut seen = vec![false; n as usize];
                for p in &pts {
                    let cell = if m == 0 { 0 } else { (p[d] >> (32 - m)) as usize };
                    assert!(!seen[cell], "dimension {d}, n = {n}: two points in interval {cell}");
                    seen[cell] = true;
                }
            }
            for a in 0..=m {
                let mut seen = vec![false; n as usize];
                for p in &pts {
                    let (cx, cy) = (
                        if a == 0 { 0 } else { p[0] >> (32 - a) },
                        if a == m { 0 } else { p[1] >> (32 - (m - a)) },
                    );
                    let cell = ((cx << (m - a)) | cy) as usize;
                    assert!(!seen[cell], "n = {n}: two points in rectangle {a}x{}", m - a);
                    seen[cell] = true;
                }
            }
        }
    }

    /// A digital shift keeps each sample's marginal uniform: over random scrambles, the mean of
    /// each coordinate of each of 4 samples is 1/2.
    #[test]
    fn scrambled_samples_are_uniform() {
        let mut rng = crate::rng::Rng::new(5, crate::rng::Stream::Direct, 0);
        let trials = 20_000;
        let mut sums = [[0.0f64; 3]; 4];
        for _ in 0..trials {
            let scramble = [rng.next_u32(), rng.next_u32(), rng.next_u32()];
            for (j, s) in sums.iter_mut().enumerate() {
                let u = scrambled_sobol3(j as u32, scramble);
                for d in 0..3 {
                    assert!((0.0..1.0).contains(&u[d]));
                    s[d] += u[d] as f64;
                }
            }
        }
        for s in sums {
            for d in s {
                assert!((d / trials as f64 - 0.5).abs() < 0.01, "mean {}", d / trials as f64);
            }
        }
    }

    #[test]
    fn basis_is_orthonormal_for_awkward_normals() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.0, 0.0, -0.99999).normalize(),
            Vec3::new(1.0, 2.0, -3.0).normalize(),
        ] {
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
