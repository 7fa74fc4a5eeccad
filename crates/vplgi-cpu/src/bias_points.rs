//! Stage `bias_points`: the bias compensation of the geometry-term clamp (Kollig and Keller,
//! "Illumination in the presence of weak singularities", 2004).
//!
//! The clamp (`shade`) replaces a VPL's a_p G(p, y), the receiver's lobe a_p =
//! `Surface::lobe` (1 on a diffuse surface) times G = cos θ_p cos θ_y / |p − y|², by
//! min(a_p G, g_max), which loses, at shading point p seen from ω_v,
//!
//! ```text
//!   ΔL(p) = ∫ f_p(ω_v, ω) L_r(y → p) w(p, y) cos θ_p dω,     w = max(0, 1 − g_max / (a_p G))
//! ```
//!
//! Sampling ω by p's BSDF (by cos θ_p / π on a diffuse surface) leaves one term per shading
//! point, the sample's weight f_p cos θ_p / pdf times w L_r(y): the direction is traced to the
//! surface y it sees, and y becomes a shading point of its own, seen from p, whose albedo
//! carries ρ_y, the weight and w, so that shading it (direct light plus the VPLs, `shade`)
//! gives the term. Its own clamped VPLs are compensated the same way one level further. Where
//! the clamp does not bite (w = 0, the common case: surfaces farther apart than d_min and off a
//! glossy peak) the point is a miss and costs nothing more. y's emission is not counted: light
//! emitted from y towards p is p's direct light, which `shade` samples without a clamp.

use crate::shade::geometry_term;
use crate::CpuScene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use vplgi_shared::bsdf::Transport;
use vplgi_types::{sampling, BiasParams, Rng, ShadingPoint, Stream, MISS};

/// The clamped share 1 − g_max / (a G) of a pair of surface points (p with normal `np`, y with
/// normal `ny`, both unit and facing each other for a positive share; `lobe` the receiver's a,
/// `Surface::lobe`, toward y), or 0 where the clamp does not bite.
#[inline]
pub fn clamped_share(p: Vec3, np: Vec3, y: Vec3, ny: Vec3, g_max: f32, lobe: f32) -> f32 {
    // The unclamped a G (0 where the pair faces away), which the clamp would cut at g_max.
    let g = geometry_term(p, np, y, ny, f32::INFINITY) * lobe;
    if g > g_max {
        1.0 - g_max / g
    } else {
        0.0
    }
}

/// The next level of compensation points of `parents` (camera samples `first ..`): one per
/// parent, a miss where the parent is a miss, the segment escapes or meets a mirror or glass, or
/// the clamp does not bite.
pub fn bias_points(cs: &CpuScene, parents: &[ShadingPoint], first: u32, params: &BiasParams) -> Vec<ShadingPoint> {
    parents.par_iter().enumerate().map(|(k, sp)| bias_point(cs, sp, first + k as u32, params)).collect()
}

/// The compensation point of shading point `sp` (sample `index`).
pub fn bias_point(cs: &CpuScene, sp: &ShadingPoint, index: u32, params: &BiasParams) -> ShadingPoint {
    let miss = ShadingPoint { pixel: sp.pixel, triangle: MISS, ..Default::default() };
    if sp.is_miss() {
        return miss;
    }
    let (p, n) = (Vec3::from(sp.position), Vec3::from(sp.normal));
    let mut rng = Rng::new(params.seed, Stream::Bias, index);
    let surface = cs.scene.materials[sp.material as usize].surface;
    let view = Vec3::from(sp.view);
    // The direction and the sample's weight f cos / pdf over the colour (1 for a diffuse surface).
    let (dir, weight) = if surface.is_glossy() {
        let (u1, u) = (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
        let Some(s) = surface.with_colour(Vec3::ONE).sample_about(n, view, u1, u, Transport::Radiance) else {
            return miss;
        };
        (s.wo, s.weight)
    } else {
        (sampling::cosine_hemisphere(n, rng.next_f32(), rng.next_f32()), Vec3::ONE)
    };
    // Leave along the geometric normal on the side the shading normal faces, as the light
    // particles do; a direction under the surface (shading normals can allow it) sees nothing.
    let ng = cs.scene.geometric_normal(sp.triangle as usize);
    let ng = if ng.dot(n) < 0.0 { -ng } else { ng };
    if dir.dot(ng) <= 0.0 {
        return miss;
    }
    let Some(hit) = cs.trace(p + ng * cs.eps, dir) else {
        return miss;
    };
    // The clamp cut only light from VPLs near p, and no VPL sits on a mirror or glass: what p
    // sees through one is light VPLs never carried (a caustic), not light the clamp removed.
    if hit.bsdf().is_specular() {
        return miss;
    }
    let w = clamped_share(p, n, hit.position, hit.ns, params.g_max, surface.lobe(n, view, dir));
    if w <= 0.0 {
        return miss;
    }
    ShadingPoint {
        position: hit.position.to_array(),
        pixel: sp.pixel,
        normal: hit.ns.to_array(),
        triangle: hit.triangle,
        material: hit.material,
        albedo: (hit.albedo * Vec3::from(sp.albedo) * weight * w).to_array(),
        view: (-dir).to_array(),
        ..Default::default()
    }
}

impl vplgi_frame::stages::BiasPoints for CpuScene<'_> {
    fn bias_points(&self, parent: &Vec<ShadingPoint>, samples: std::ops::Range<u32>, params: &BiasParams) -> Result<Vec<ShadingPoint>, vplgi_frame::FrameError> {
        Ok(bias_points(self, parent, samples.start, params))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clamped_share_is_what_the_clamp_removes() {
        let (p, up, down) = (Vec3::ZERO, Vec3::Z, -Vec3::Z);
        // Facing each other head-on 0.1 apart: G = 1 / 0.01 = 100; with g_max = 25 the clamp
        // keeps 25 of it and removes 75, a share of 0.75.
        assert!((clamped_share(p, up, Vec3::new(0.0, 0.0, 0.1), down, 25.0, 1.0) - 0.75).abs() < 1e-6);
        // At 45 degrees to both normals and sqrt(2) * 0.1 apart: G = 0.5 / 0.02 = 25: the clamp
        // no longer bites.
        let y = Vec3::new(0.1, 0.0, 0.1);
        let ny = Vec3::new(-1.0, 0.0, 0.0);
        assert!((clamped_share(p, up, y, ny, 12.5, 1.0) - 0.5).abs() < 1e-5);
        assert_eq!(clamped_share(p, up, y, ny, 25.0 + 1e-3, 1.0), 0.0);
        // Facing away, or the same point: nothing to put back.
        assert_eq!(clamped_share(p, up, Vec3::new(0.0, 0.0, 0.1), up, 1.0, 1.0), 0.0);
        assert_eq!(clamped_share(p, up, p, down, 1.0, 1.0), 0.0);
        // Without a clamp nothing is removed.
        assert_eq!(clamped_share(p, up, Vec3::new(0.0, 0.0, 1e-3), down, f32::INFINITY, 1.0), 0.0);
    }
}
