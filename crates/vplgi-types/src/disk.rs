//! VPL clusters as disk-shaped area lights (Prutkin, Kaplanyan and Dachsbacher 2012, section 5).
//!
//! A cluster's flux Φ leaves a disk of area A = π R² around its representative, facing the
//! cluster's normal, instead of a point. The form factor from a point p to the disk is
//! approximated by their Eq. 2 (Wallace et al.'s point-to-disk form factor):
//!
//! ```text
//!   ∫_disk G(p, z) / π dA_z  ≈  A cos θ_p cos θ_c / (A + π d²)
//! ```
//!
//! so the irradiance the disk gives p is Φ / (π A) · π · Eq. 2 = (Φ / π) · cos θ_p cos θ_c /
//! (d² + R²): a point light's with d² replaced by d² + R² ([`geometry_term`]). It is exact on the
//! axis of a parallel disk, bounded by 1 / R² as d → 0, and needs no clamp.
//!
//! The radius comes from the members' spread ([`radius2`]): a disk whose flux is spread evenly
//! has a mean squared distance from its centre of R² / 2, so R² is twice the flux-weighted mean
//! squared distance of the members from their flux-weighted centre, measured in the plane of the
//! cluster's normal. A cluster of one VPL has no extent (R = 0) and stays a clamped point.

use glam::Vec3;

/// How much a member counts in the disk's moments: its flux summed over the channels.
#[inline]
pub fn member_weight(flux: Vec3) -> f32 {
    flux.x + flux.y + flux.z
}

/// Eq. 2 as a geometry term: cos θ_p cos θ_c / (d² + R²), for cosines already known positive.
#[inline]
pub fn geometry_term(cos_p: f32, cos_c: f32, d2: f32, radius2: f32) -> f32 {
    cos_p * cos_c / (d2 + radius2)
}

/// The disk of a set of members (position, flux) whose light faces `normal`: R², twice the
/// flux-weighted mean squared distance of the members from their flux-weighted centre in the
/// plane orthogonal to `normal`. Sums run in member order (the GPU's order too), first the
/// weights and weighted positions, then the spread; 0 for members without flux.
pub fn radius2(members: impl Iterator<Item = (Vec3, Vec3)> + Clone, normal: Vec3) -> f32 {
    let mut weight = 0.0f32;
    let mut moment = Vec3::ZERO;
    for (x, flux) in members.clone() {
        let w = member_weight(flux);
        weight += w;
        moment += x * w;
    }
    if weight.is_nan() || weight <= 0.0 {
        return 0.0;
    }
    let centre = moment / weight;
    let mut spread = 0.0f32;
    for (x, flux) in members {
        spread += member_weight(flux) * in_plane2(x - centre, normal);
    }
    2.0 * spread / weight
}

/// |d|² minus its squared component along the unit `normal`: the squared distance in the plane.
#[inline]
pub fn in_plane2(d: Vec3, normal: Vec3) -> f32 {
    let along = normal.dot(d);
    (d.length_squared() - along * along).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Rng, Stream};
    use std::f64::consts::PI;

    /// The exact form factor from the point at `p` with normal `np` to the disk of radius `r`
    /// centred at the origin in the plane z = 0, facing +z: ∫ cos cos / (π d²) dA by the
    /// midpoint rule in polar coordinates, in double precision.
    fn form_factor_by_quadrature(p: [f64; 3], np: [f64; 3], r: f64) -> f64 {
        // rho = r u², so the samples crowd towards the centre, where a point just above the
        // disk's centre has its peak.
        let (nr, nphi) = (800, 1600);
        let mut sum = 0.0;
        for i in 0..nr {
            let u = (i as f64 + 0.5) / nr as f64;
            let rho = r * u * u;
            let jacobian = 2.0 * r * u;
            for j in 0..nphi {
                let phi = (j as f64 + 0.5) / nphi as f64 * 2.0 * PI;
                let z = [rho * phi.cos(), rho * phi.sin(), 0.0];
                let d = [z[0] - p[0], z[1] - p[1], z[2] - p[2]];
                let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let cos_p = (np[0] * d[0] + np[1] * d[1] + np[2] * d[2]) / d2.sqrt();
                let cos_z = -d[2] / d2.sqrt();
                if cos_p > 0.0 && cos_z > 0.0 {
                    sum += cos_p * cos_z / (PI * d2) * rho * jacobian;
                }
            }
        }
        sum * (1.0 / nr as f64) * (2.0 * PI / nphi as f64)
    }

    /// Eq. 2 for the same configuration, through [`geometry_term`] (G / π · A is the form factor
    /// of the disk seen as one light: (cos cos / (d² + R²)) · R², since A / π = R²).
    fn form_factor_eq2(p: [f64; 3], np: [f64; 3], r: f64) -> f64 {
        let p = Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32);
        let np = Vec3::new(np[0] as f32, np[1] as f32, np[2] as f32);
        let d = -p;
        let d2 = d.length_squared();
        let (cos_p, cos_c) = (np.dot(d) / d2.sqrt(), -d.z / d2.sqrt());
        geometry_term(cos_p, cos_c, d2, (r * r) as f32) as f64 * r * r
    }

    #[test]
    fn on_the_axis_of_a_parallel_disk_eq2_is_exact() {
        for (r, h) in [(1.0, 1.0), (0.5, 2.0), (2.0, 0.25), (0.01, 3.0), (3.0, 0.01)] {
            let exact = r * r / (r * r + h * h);
            let eq2 = form_factor_eq2([0.0, 0.0, h], [0.0, 0.0, -1.0], r);
            let quad = form_factor_by_quadrature([0.0, 0.0, h], [0.0, 0.0, -1.0], r);
            println!("R {r}, h {h}: exact {exact:.6}, Eq. 2 {eq2:.6}, quadrature {quad:.6}");
            assert!((eq2 - exact).abs() <= 1e-6 * exact.max(1e-3), "Eq. 2 {eq2} vs R²/(R²+h²) {exact}");
            // The quadrature itself is checked against the closed form.
            assert!((quad - exact).abs() <= 1e-4 * exact, "quadrature {quad} vs {exact}");
        }
    }

    /// Off the axis Eq. 2 is an approximation whose relative error shrinks as (R / d)²: it
    /// differs from the exact form factor only through the disk's extent. Measured against
    /// quadrature along five directions (receivers tilted up to 45 degrees), each doubling of the
    /// distance must divide the error by 3 to 5 once d >= 4R (second order), and the error stays
    /// within the envelope 4 (R / d)² (measured: at most 12 % at 4R, 0.2 % at 32R).
    /// A wrong power of d, a missing cosine or a wrong radius makes the error settle at a constant
    /// instead (the first two) or keeps it from vanishing on the axis (the last).
    #[test]
    fn off_the_axis_eq2_converges_to_the_form_factor() {
        let cases = [([0.6f64, 0.2, 1.0], 0.0f64), ([1.0, 0.0, 1.0], 20.0), ([0.3, 0.8, 1.0], -35.0), ([1.5, 1.0, 1.0], -45.0), ([0.0, 0.7, 1.0], 10.0)];
        for (dir, deg) in cases {
            let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            let a = deg.to_radians();
            let np = [a.sin(), 0.0, -a.cos()];
            let errors: Vec<f64> = [4.0f64, 8.0, 16.0, 32.0]
                .iter()
                .map(|&d| {
                    let p = [dir[0] / len * d, dir[1] / len * d, dir[2] / len * d];
                    let (eq2, quad) = (form_factor_eq2(p, np, 1.0), form_factor_by_quadrature(p, np, 1.0));
                    (eq2 - quad).abs() / quad
                })
                .collect();
            println!(
                "direction {dir:?}, tilt {deg} deg: relative error at d = 4, 8, 16, 32 R: {:?}",
                errors.iter().map(|e| format!("{e:.2e}")).collect::<Vec<_>>()
            );
            for w in errors.windows(2) {
                let ratio = w[0] / w[1];
                assert!((3.0..=5.0).contains(&ratio), "error ratio {ratio} per doubling of d: {errors:?}");
            }
            for (e, d) in errors.iter().zip([4.0f64, 8.0, 16.0, 32.0]) {
                assert!(*e <= 4.0 / (d * d), "error {e} at d = {d} R beyond 4 (R / d)²");
            }
        }
    }

    #[test]
    fn members_spread_evenly_over_a_disk_give_its_radius() {
        let mut rng = Rng::new(7, Stream::Oracle, 0);
        let (normal, r) = (Vec3::new(0.0, 0.6, 0.8), 0.7f32);
        let (t, b) = (Vec3::X, normal.cross(Vec3::X));
        let centre = Vec3::new(1.0, -2.0, 3.0);
        let members: Vec<(Vec3, Vec3)> = (0..20_000)
            .map(|_| {
                let (u, v) = (rng.next_f32(), rng.next_f32());
                let (rho, phi) = (r * u.sqrt(), 2.0 * std::f32::consts::PI * v);
                (centre + t * rho * phi.cos() + b * rho * phi.sin(), Vec3::new(0.2, 0.3, 0.1))
            })
            .collect();
        let r2 = radius2(members.iter().copied(), normal);
        println!("R² of 20,000 members of a disk of R² {}: {r2}", r * r);
        assert!((r2 / (r * r) - 1.0).abs() < 0.02, "{r2}");
        // Moving the members along the normal changes nothing; scaling the flux changes nothing.
        let lifted = members.iter().enumerate().map(|(i, &(x, f))| (x + normal * (i % 7) as f32, f * 3.0));
        assert!((radius2(lifted, normal) / r2 - 1.0).abs() < 1e-3);
    }

    #[test]
    fn flux_weights_the_spread() {
        // Two members 2 apart: equal flux puts the centre between them (R² = 2 · 1 = 2); all the
        // flux on one makes a point (R² = 0); 3:1 gives 2 · (3 · 0.25 + 1 · 2.25) / 4 = 1.5.
        let n = Vec3::Z;
        let m = |f0: f32, f1: f32| radius2([(Vec3::ZERO, Vec3::splat(f0)), (Vec3::X * 2.0, Vec3::splat(f1))].into_iter(), n);
        assert_eq!(m(1.0, 1.0), 2.0);
        assert_eq!(m(1.0, 0.0), 0.0);
        assert!((m(3.0, 1.0) - 1.5).abs() < 1e-6);
        assert_eq!(radius2(std::iter::empty(), n), 0.0);
        assert_eq!(m(0.0, 0.0), 0.0);
    }
}
