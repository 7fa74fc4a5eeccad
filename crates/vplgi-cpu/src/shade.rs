//! Stage 5, `shade`: the radiance of every pixel, Eq. 6 with the visibility of Eq. 8 or 9/10,
//! plus emitted and direct light.
//!
//! For shading point p and each VPL (cluster) c with flux Φ_c at x_c with normal n_c:
//!
//! ```text
//!   L_ind(p) = Σ_c  Φ_c · (ρ_p / π) · G(p, x_c) / π · Ṽ(p, c)
//!   G        = min(cos θ_p cos θ_c / |p − x_c|², 1 / d_min²)
//! ```
//!
//! Φ_c cos θ_c / π is the radiant intensity of a Lambertian VPL, and ρ_p / π the Lambertian
//! BRDF (Eq. 6's I_c ρ G). Ṽ is the shading point's own visibility bit when shading points are
//! not clustered, else the weighted (Eq. 9, 10) or plain (Eq. 8) mean of its F clusters' bits.
//! Clamping G at 1/d_min² removes the splotches of VPLs close to a surface at a small energy
//! loss; d_min is relative to the scene size (SPEC, "geometry-term clamp").

use crate::visibility::{BitMatrix, Endpoint};
use crate::CpuScene;
use glam::Vec3;
use std::f32::consts::PI;
use vplgi_scene::PunctualLight;
use vplgi_types::config::MAX_F;
use vplgi_types::{Rng, ShadingPoint, Stream, MISS};

/// A light for indirect shading: one VPL, or one VPL cluster at its representative.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VplLight {
    pub position: Vec3,
    pub normal: Vec3,
    pub flux: Vec3,
}

impl VplLight {
    pub fn endpoint(&self) -> Endpoint {
        Endpoint { position: self.position, normal: self.normal }
    }
}

/// Where a shading point's visibility of each VPL light comes from.
#[derive(Clone, Copy, Debug)]
pub enum VisibilitySource<'a> {
    /// Row `row_of[i] - first_row` of the matrix belongs to shading point i itself.
    Own { matrix: &'a BitMatrix, row_of: &'a [u32], first_row: u32 },
    /// Shading point i belongs to clusters `labels[row_of[i] * f ..][..f]` with `weights`; the
    /// matrix has one row per cluster.
    Fuzzy { matrix: &'a BitMatrix, row_of: &'a [u32], labels: &'a [u32], weights: &'a [f32], f: usize },
}

/// Geometry term with the clamp; zero when either surface faces away.
#[inline]
pub fn geometry_term(p: Vec3, np: Vec3, x: Vec3, nx: Vec3, g_max: f32) -> f32 {
    let d = x - p;
    let d2 = d.length_squared();
    if d2 <= 0.0 {
        return 0.0;
    }
    let inv_d = d2.sqrt().recip();
    let cos_p = np.dot(d) * inv_d;
    let cos_x = -nx.dot(d) * inv_d;
    if cos_p <= 0.0 || cos_x <= 0.0 {
        return 0.0;
    }
    (cos_p * cos_x / d2).min(g_max)
}

/// Indirect radiance at shading point `i` (Eq. 6).
pub fn indirect(sp: &ShadingPoint, i: usize, lights: &[VplLight], vis: &VisibilitySource, g_max: f32) -> Vec3 {
    let p = Vec3::from(sp.position);
    let n = Vec3::from(sp.normal);
    let brdf = Vec3::from(sp.albedo) / PI;
    // The visibility source is resolved once per shading point, so the per-light loop is a
    // monomorphised closure over plain slices.
    let sum = match *vis {
        VisibilitySource::Own { matrix, row_of, first_row } => {
            let row = matrix.row((row_of[i] - first_row) as usize);
            sum_lights(p, n, lights, g_max, |c| if bit(row, c) { 1.0 } else { 0.0 })
        }
        VisibilitySource::Fuzzy { matrix, row_of, labels, weights, f } => {
            let r = row_of[i] as usize * f;
            let mut rows: [&[u64]; MAX_F as usize] = [&[]; MAX_F as usize];
            let mut w = [0.0f32; MAX_F as usize];
            let mut count = 0;
            for j in 0..f {
                if labels[r + j] != MISS {
                    rows[count] = matrix.row(labels[r + j] as usize);
                    w[count] = weights[r + j];
                    count += 1;
                }
            }
            let (rows, w) = (&rows[..count], &w[..count]);
            sum_lights(p, n, lights, g_max, |c| {
                let mut v = 0.0;
                for (row, &wf) in rows.iter().zip(w) {
                    if bit(row, c) {
                        v += wf;
                    }
                }
                v
            })
        }
    };
    sum * brdf
}

#[inline(always)]
fn bit(row: &[u64], c: usize) -> bool {
    (row[c / 64] >> (c % 64)) & 1 == 1
}

/// Σ_c Φ_c G / π Ṽ(c) over the lights, Ṽ given by `vis`.
#[inline(always)]
fn sum_lights(p: Vec3, n: Vec3, lights: &[VplLight], g_max: f32, vis: impl Fn(usize) -> f32) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for (c, l) in lights.iter().enumerate() {
        let g = geometry_term(p, n, l.position, l.normal, g_max);
        if g == 0.0 {
            continue;
        }
        let v = vis(c);
        if v > 0.0 {
            sum += l.flux * (g / PI * v);
        }
    }
    sum
}

/// Direct light at shading point `index`: `samples` shadow rays to points on area lights chosen
/// by power (stream (seed, `Stream::Direct`, index)), plus one shadow ray per punctual light.
pub fn direct(cs: &CpuScene, sp: &ShadingPoint, index: u32, seed: u32, samples: u32) -> Vec3 {
    let p = Vec3::from(sp.position);
    let n = Vec3::from(sp.normal);
    let brdf = Vec3::from(sp.albedo) / PI;
    let mut sum = Vec3::ZERO;
    let mut rng = Rng::new(seed, Stream::Direct, index);
    let mut area = Vec3::ZERO;
    for _ in 0..samples {
        let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
        let Some(s) = cs.lights.sample_area(cs.scene, u) else {
            break;
        };
        let d = s.position - p;
        let d2 = d.length_squared();
        let cos_p = n.dot(d);
        let cos_l = -s.normal.dot(d);
        // Emission leaves the front side only.
        if d2 <= 0.0 || cos_p <= 0.0 || cos_l <= 0.0 {
            continue;
        }
        if cs.visible(p, n, s.position, s.normal) {
            area += s.radiance * (cos_p * cos_l / (d2 * d2) / s.pdf_area);
        }
    }
    sum += area / samples.max(1) as f32;
    for l in cs.lights.punctual() {
        let (PunctualLight::Point { position, intensity } | PunctualLight::Spot { position, intensity, .. }) = l;
        let d = *position - p;
        let d2 = d.length_squared();
        let cos_p = n.dot(d);
        if d2 <= 0.0 || cos_p <= 0.0 {
            continue;
        }
        let falloff = l.falloff(-d / d2.sqrt());
        if falloff > 0.0 && cs.visible_from_surface(p, n, *position) {
            sum += *intensity * (falloff * cos_p / (d2 * d2.sqrt()));
        }
    }
    sum * brdf
}

/// Radiance of shading point `i`: emitted + direct + indirect (zero for a miss).
#[allow(clippy::too_many_arguments)]
pub fn shade_point(cs: &CpuScene, sps: &[ShadingPoint], i: usize, lights: &[VplLight], vis: &VisibilitySource, g_max: f32, seed: u32, direct_samples: u32) -> Vec3 {
    let sp = &sps[i];
    if sp.triangle == MISS {
        return Vec3::ZERO;
    }
    Vec3::from(sp.emitted) + direct(cs, sp, i as u32, seed, direct_samples) + indirect(sp, i, lights, vis, g_max)
}

/// Shades pixels `pixels` (a range of pixel indices), averaging their `spp` shading points in
/// sample order. Returns one RGB value per pixel of the range.
#[allow(clippy::too_many_arguments)]
pub fn shade(
    cs: &CpuScene,
    sps: &[ShadingPoint],
    spp: u32,
    pixels: std::ops::Range<usize>,
    lights: &[VplLight],
    vis: &VisibilitySource,
    g_max: f32,
    seed: u32,
    direct_samples: u32,
) -> Vec<[f32; 3]> {
    use rayon::prelude::*;
    let spp = spp as usize;
    pixels
        .into_par_iter()
        .map(|px| {
            let mut sum = Vec3::ZERO;
            for s in 0..spp {
                sum += shade_point(cs, sps, px * spp + s, lights, vis, g_max, seed, direct_samples);
            }
            (sum / spp as f32).to_array()
        })
        .collect()
}
