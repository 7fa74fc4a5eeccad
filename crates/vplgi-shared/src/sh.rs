//! The glossy last bounce of `--gi photon` (Wang et al. 2009, section 3.5): each sample point
//! keeps its incident light in real spherical harmonics of bands l = 0..3 (16 coefficients a
//! channel), shading points interpolate the coefficients with the irradiance's weights, and a
//! glossy receiver integrates the result against its own lobe.
//!
//! What is projected is the cosine-weighted incident radiance g(ω) = L_i(ω) max(0, n_j · ω) in
//! world directions, g_k = ∫ g Y_k dω. Final gathering's rays are cosine-distributed (pdf
//! cos θ / π), so each ray k adds (π / N) L(y_k) Y(ω_k) = (1 / N) ρ_y Ê(y_k) Y(ω_k): no ray is
//! divided by its cosine, which would make grazing rays dominate. The DC term is then exactly
//! Y_0 E, Eq. 1's irradiance, so a diffuse receiver needs only E. A glossy receiver x with
//! normal n_x ≈ n_j reflects (ρ / π) ∫ L_i cos θ_x a(ω) dω ≈ (ρ / π) ∫ g̃⁺(ω) a(ω) dω, a the
//! lobe over a white Lambertian surface's (`Surface::lobe`) and g̃⁺ the reconstruction clamped at
//! 0 (it rings where g has its kink, the horizon).
//!
//! Order 4 holds only broad lobes: a reflection narrower than the bands (GGX α below about 0.3,
//! glTF roughness below about 0.55) comes out as wide as they are, and loses its highlight.

use crate::bsdf::{Bsdf, Surface, Transport};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use vplgi_types::params::{GLOSSY_DIRECTIONS, SH_COEFFICIENTS};

/// A sample point's cosine-weighted incident light: coefficient k of channel c at `[k][c]`
/// (192 bytes).
pub type ShRgb = [[f32; 3]; SH_COEFFICIENTS];

/// The normalisation constants of the real basis, band by band (shared with WGSL through the
/// generated prelude): 1/(2√π); √(3/4π); √(15/4π), √(5/16π), √(15/16π); √(35/32π), √(105/4π),
/// √(21/32π), √(7/16π), √(105/16π).
pub const SH_L0: f32 = 0.282_094_8;
pub const SH_L1: f32 = 0.488_602_5;
pub const SH_L2_XY: f32 = 1.092_548_4;
pub const SH_L2_ZZ: f32 = 0.315_391_57;
pub const SH_L2_XX: f32 = 0.546_274_2;
pub const SH_L3_XXY: f32 = 0.590_043_6;
pub const SH_L3_XYZ: f32 = 2.890_611_4;
pub const SH_L3_YZZ: f32 = 0.457_045_8;
pub const SH_L3_ZZZ: f32 = 0.373_176_33;
pub const SH_L3_ZXX: f32 = 1.445_305_7;

/// The 16 real basis functions at the unit direction `d`, in the order (l, m) = (0, 0),
/// (1, −1), (1, 0), (1, 1), (2, −2) … (3, 3); `common/sh.wgsl` evaluates the same operations.
pub fn basis(d: Vec3) -> [f32; SH_COEFFICIENTS] {
    let (x, y, z) = (d.x, d.y, d.z);
    let (x2, y2, z2) = (x * x, y * y, z * z);
    [
        SH_L0,
        SH_L1 * y,
        SH_L1 * z,
        SH_L1 * x,
        SH_L2_XY * (x * y),
        SH_L2_XY * (y * z),
        SH_L2_ZZ * (3.0 * z2 - 1.0),
        SH_L2_XY * (x * z),
        SH_L2_XX * (x2 - y2),
        SH_L3_XXY * (y * (3.0 * x2 - y2)),
        SH_L3_XYZ * (x * y * z),
        SH_L3_YZZ * (y * (5.0 * z2 - 1.0)),
        SH_L3_ZZZ * (z * (5.0 * z2 - 3.0)),
        SH_L3_YZZ * (x * (5.0 * z2 - 1.0)),
        SH_L3_ZXX * (z * (x2 - y2)),
        SH_L3_XXY * (x * (x2 - 3.0 * y2)),
    ]
}

/// Adds `c` arriving from direction `d` to `sh`: c Y_k(d) to each coefficient.
pub fn accumulate(sh: &mut ShRgb, d: Vec3, c: Vec3) {
    for (k, y) in basis(d).into_iter().enumerate() {
        for ch in 0..3 {
            sh[k][ch] += c[ch] * y;
        }
    }
}

/// g̃(d) = Σ_k g_k Y_k(d), clamped at 0 in each channel.
pub fn reconstruct(sh: &ShRgb, d: Vec3) -> Vec3 {
    let mut g = Vec3::ZERO;
    for (k, y) in basis(d).into_iter().enumerate() {
        g += Vec3::from(sh[k]) * y;
    }
    g.max(Vec3::ZERO)
}

/// Point m of the glossy quadrature's Hammersley set on the unit square: ((m + ½) / M, the
/// base-2 radical inverse of m).
pub fn quadrature_point(m: u32) -> Vec2 {
    Vec2::new(
        (m as f32 + 0.5) / GLOSSY_DIRECTIONS as f32,
        m.reverse_bits() as f32 * (1.0 / 4_294_967_296.0),
    )
}

/// What a receiver of `surface` at normal `n`, seen from the unit direction `view`, takes in
/// place of the irradiance so that ρ / π times it is its reflected radiance: `irradiance` itself
/// where it is diffuse; for rough metal Q = ∫ g̃⁺(ω) a(ω) dω, estimated with the lobe's own
/// visible-normal samples at the fixed points [`quadrature_point`]: Q ≈ (π / M) Σ g̃⁺(ω_m)
/// w_m / cos θ_m, w the sample's weight (f cos θ / pdf for a white lobe); a blend takes
/// (1 − metallic) E + metallic Q.
pub fn glossy_irradiance(
    sh: &ShRgb,
    irradiance: Vec3,
    surface: Surface,
    n: Vec3,
    view: Vec3,
) -> Vec3 {
    let (metallic, alpha) = match surface {
        Surface::RoughConductor { alpha } => (1.0, alpha),
        Surface::Blend { metallic, alpha } => (metallic, alpha),
        _ => return irradiance,
    };
    let lobe = Bsdf::RoughConductor { reflectance: Vec3::ONE, alpha };
    let mut q = Vec3::ZERO;
    for m in 0..GLOSSY_DIRECTIONS {
        let Some(s) = lobe.sample_about(n, view, 0.0, quadrature_point(m), Transport::Radiance)
        else {
            continue;
        };
        let cos = s.wo.dot(n);
        if cos > 0.0 {
            q += reconstruct(sh, s.wo) * (s.weight.x / cos);
        }
    }
    irradiance * (1.0 - metallic) + q * (metallic * PI / GLOSSY_DIRECTIONS as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI as PI64;

    /// The basis by its defining formulas in f64, from the associated Legendre polynomials in
    /// spherical coordinates: an independent computation of every constant and polynomial.
    fn legendre_basis(d: Vec3) -> [f64; 16] {
        let (x, y, z) = (d.x as f64, d.y as f64, d.z as f64);
        let theta = z.clamp(-1.0, 1.0).acos();
        let phi = y.atan2(x);
        let fact = |n: i64| (1..=n).map(|k| k as f64).product::<f64>();
        // P_l^m(cos θ) for m ≥ 0 without the Condon–Shortley phase.
        let p = |l: i64, m: i64| -> f64 {
            let (c, s) = (theta.cos(), theta.sin());
            match (l, m) {
                (0, 0) => 1.0,
                (1, 0) => c,
                (1, 1) => s,
                (2, 0) => 0.5 * (3.0 * c * c - 1.0),
                (2, 1) => 3.0 * s * c,
                (2, 2) => 3.0 * s * s,
                (3, 0) => 0.5 * (5.0 * c * c * c - 3.0 * c),
                (3, 1) => 1.5 * s * (5.0 * c * c - 1.0),
                (3, 2) => 15.0 * s * s * c,
                (3, 3) => 15.0 * s * s * s,
                _ => unreachable!(),
            }
        };
        let mut out = [0.0; 16];
        let mut i = 0;
        for l in 0..4i64 {
            for m in -l..=l {
                let a = m.abs();
                let k = ((2 * l + 1) as f64 / (4.0 * PI64) * fact(l - a) / fact(l + a)).sqrt();
                out[i] = match m {
                    0 => k * p(l, 0),
                    m if m > 0 => 2f64.sqrt() * k * (m as f64 * phi).cos() * p(l, m),
                    _ => 2f64.sqrt() * k * (a as f64 * phi).sin() * p(l, a),
                };
                i += 1;
            }
        }
        out
    }

    /// Unit directions spread over the sphere.
    fn directions(n: usize) -> impl Iterator<Item = Vec3> {
        let golden = PI64 * (3.0 - 5f64.sqrt());
        (0..n).map(move |i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
        })
    }

    #[test]
    fn the_basis_is_the_legendre_definition() {
        for d in directions(500) {
            let (got, want) = (basis(d), legendre_basis(d));
            for k in 0..16 {
                assert!(
                    (got[k] as f64 - want[k]).abs() < 2e-6,
                    "Y_{k}({d}) = {} against {}",
                    got[k],
                    want[k]
                );
            }
        }
    }

    /// The coefficients of g = L max(0, z) for a constant radiance L are the clamped cosine's
    /// zonal ones: √π / 2, √(π / 3), √(5π) / 8 and 0 at m = 0, nothing elsewhere. The DC term is
    /// Y_0 E with E = π L, which is what lets a diffuse receiver read the irradiance alone.
    #[test]
    fn a_uniform_sky_projects_to_the_clamped_cosine() {
        let mut sh = [[0.0f32; 3]; 16];
        let n = 200_000;
        let l = Vec3::new(1.0, 2.0, 0.5);
        for d in directions(n) {
            // The sphere's quadrature: weight 4π / n per direction.
            accumulate(&mut sh, d, l * d.z.max(0.0) * (4.0 * PI / n as f32));
        }
        let pi = std::f32::consts::PI;
        let zonal = [pi.sqrt() / 2.0, (pi / 3.0).sqrt(), (5.0 * pi).sqrt() / 8.0, 0.0];
        for (k, c) in sh.iter().enumerate() {
            let band = (k as f32).sqrt() as usize;
            let want = if k == band * band + band { zonal[band] } else { 0.0 };
            for ch in 0..3 {
                assert!(
                    (c[ch] - want * l[ch]).abs() < 2e-3,
                    "g_{k}[{ch}] = {} against {}",
                    c[ch],
                    want * l[ch]
                );
            }
        }
        assert!(
            (sh[0][0] / SH_L0 - pi * l.x).abs() < 1e-3,
            "DC / Y_0 = {} against E = π L",
            sh[0][0] / SH_L0
        );
    }

    /// The quadrature against a dense integration in f64 of the same reconstruction times the
    /// lobe (`Surface::lobe`, evaluated, not sampled): a light from one side, a rough and a
    /// broad lobe, seen from three angles. The fixed directions' error is the estimate's own
    /// (within 2 %); a wrong weight, cosine or π is far beyond it.
    #[test]
    fn the_lobe_quadrature_matches_dense_integration() {
        let mut sh = [[0.0f32; 3]; 16];
        accumulate(&mut sh, Vec3::new(0.6, 0.0, 0.8), Vec3::new(3.0, 1.0, 0.5));
        accumulate(&mut sh, Vec3::Z, Vec3::splat(2.0));
        let n = Vec3::Z;
        for alpha in [0.36f32, 0.8] {
            let surface = Surface::RoughConductor { alpha };
            for view in [
                Vec3::Z,
                Vec3::new(0.5, 0.0, 0.866).normalize(),
                Vec3::new(-0.8, 0.3, 0.52).normalize(),
            ] {
                let got = glossy_irradiance(&sh, Vec3::ZERO, surface, n, view);
                let mut want = [0f64; 3];
                let steps = 400;
                for i in 0..steps {
                    for j in 0..4 * steps {
                        let (u, v) = (
                            (i as f64 + 0.5) / steps as f64,
                            (j as f64 + 0.5) / (4 * steps) as f64,
                        );
                        // Uniform in cos θ over the upper hemisphere: dω = 2π du dv.
                        let (z, phi) = (u, 2.0 * PI64 * v);
                        let r = (1.0 - z * z).sqrt();
                        let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                        let g = reconstruct(&sh, d);
                        let a = surface.lobe(n, view, d) as f64;
                        for c in 0..3 {
                            want[c] += g[c] as f64 * a * 2.0 * PI64 / (steps * 4 * steps) as f64;
                        }
                    }
                }
                for c in 0..3 {
                    let rel = (got[c] as f64 - want[c]).abs() / want[c];
                    println!(
                        "α {alpha}, view {view}, channel {c}: {} against {} ({rel:.4})",
                        got[c], want[c]
                    );
                    assert!(
                        rel < 0.02,
                        "α {alpha}, view {view}: channel {c} {} against {} ({rel:.4})",
                        got[c],
                        want[c]
                    );
                }
            }
        }
    }

    #[test]
    fn diffuse_and_blended_receivers_keep_their_diffuse_share() {
        let mut sh = [[0.0f32; 3]; 16];
        accumulate(&mut sh, Vec3::Z, Vec3::ONE);
        let e = Vec3::new(4.0, 5.0, 6.0);
        assert_eq!(glossy_irradiance(&sh, e, Surface::Diffuse, Vec3::Z, Vec3::Z), e);
        let metal =
            glossy_irradiance(&sh, e, Surface::RoughConductor { alpha: 0.5 }, Vec3::Z, Vec3::Z);
        let half = glossy_irradiance(
            &sh,
            e,
            Surface::Blend { metallic: 0.25, alpha: 0.5 },
            Vec3::Z,
            Vec3::Z,
        );
        assert!(
            (half - (0.75 * e + 0.25 * metal)).abs().max_element() < 1e-5,
            "{half} against {}",
            0.75 * e + 0.25 * metal
        );
    }
}
