//! Stage 1 with `--vpl-source rsm`, `rsm_vpls`: a reflective shadow map per light (Prutkin et
//! al. 2012, after Dachsbacher and Stamminger 2005), each texel whose ray hits a surface a VPL
//! there, its flux the texel's power times the albedo (`vplgi_shared::rsm`). One bounce only.
//!
//! A map records the first surface each texel's light reaches, and a mirror or glass is not
//! one: there the ray goes on, reflected or refracted as `trace_vpls`'s particles are (power
//! through glass takes no η²; reflect or refract is chosen by Fresnel with the stream (seed,
//! `RsmSpecular`, t)), to at most `specular_depth` vertices, and the surface it then meets holds
//! the VPL, its flux times the chain's weight.
//!
//! Texel t's ray is a pure function of the maps, the seed and t, so the VPLs, in texel order
//! with `path` = t, do not depend on threads; a texel whose ray escapes (or a spot texel outside
//! the outer cone) leaves no VPL. No normalisation follows: the texels' powers already sum to
//! the lights'.

use crate::trace_vpls::VplSet;
use crate::CpuScene;
use rayon::prelude::*;
use vplgi_frame::Progress;
use vplgi_shared::bsdf::Transport;
use vplgi_shared::rsm::{self, RsmLight};
use vplgi_types::{Rng, RsmParams, Stream, Vpl};
use vplgi_frame::FrameError;

/// The VPL of texel `t` of `maps`, if its ray, through its mirrors and glass, hits a surface.
pub fn texel_vpl(cs: &CpuScene, maps: &[RsmLight], t: u32, params: &RsmParams) -> Option<Vpl> {
    follow_texel(cs, &rsm::texel_ray(&maps[rsm::map_of(maps, t)], t)?, t, params)
}

/// The VPL of texel `t` whose ray is `ray`: what [`texel_vpl`] does once it has the ray.
pub fn follow_texel(cs: &CpuScene, ray: &rsm::TexelRay, t: u32, params: &RsmParams) -> Option<Vpl> {
    let mut chain = Rng::new(params.seed, Stream::RsmSpecular, t);
    let (mut origin, mut dir, mut power) = (ray.origin + ray.surface_normal * cs.eps, ray.dir, ray.power);
    let mut specular = 0;
    loop {
        let hit = cs.trace(origin, dir)?;
        if specular == params.specular_depth || !hit.bsdf().is_specular() {
            let flux = power * hit.albedo;
            return Some(Vpl {
                position: hit.position.to_array(),
                path: t,
                normal: hit.ns.to_array(),
                bounce: 1,
                flux: flux.to_array(),
                specular,
                incoming: (-dir).to_array(),
                material: hit.material,
            });
        }
        let (out, weight) = hit.scatter_specular(dir, chain.next_f32(), Transport::Importance)?;
        power *= weight;
        specular += 1;
        dir = out;
        origin = cs.offset_toward(hit.position, hit.ng, hit.position + dir);
    }
}

/// The VPLs of the maps of every light of the scene for a budget of about `params.size²`
/// texels.
pub fn rsm_vpls(cs: &CpuScene, params: &RsmParams, progress: &dyn Progress) -> VplSet {
    let maps = cs.lights.rsm_maps(params.size);
    let texels = rsm::texel_count(&maps);
    progress.start("rsm_vpls", 1);
    let vpls: Vec<Vpl> = (0..texels).into_par_iter().filter_map(|t| texel_vpl(cs, &maps, t, params)).collect();
    progress.finish();
    VplSet { vpls, particles: texels }
}

impl vplgi_frame::stages::RsmVpls for CpuScene<'_> {
    fn rsm_vpls(&self, params: &RsmParams, progress: &dyn Progress) -> Result<(Vec<Vpl>, u32), FrameError> {
        let set = rsm_vpls(self, params, progress);
        Ok((set.vpls, set.particles))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// A point light of intensity I at height h over the centre of a square of half-side a = 4 and
    /// albedo ρ: the VPLs' total flux is ρ I Ω, the solid angle of the square seen from the light
    /// being Ω = 4 arcsin(a² / (a² + h²)). The map's texels resolve the square's edge to about one
    /// texel of the sphere map's 512 rows, so they agree within 0.5 %.
    #[test]
    fn a_point_light_over_a_square_sends_it_its_solid_angle() {
        let (size, h, rho, intensity) = (4.0f32, 1.0f32, 0.5f32, 2.0f32);
        let scene = vplgi_scene::cornell::plane_with_point_light(size, h, rho, intensity);
        let device = vplgi_embree::Device::new(None).expect("embree");
        let cs = CpuScene::new(&scene, &device).expect("scene");
        let set = rsm_vpls(&cs, &RsmParams::new(512, 1), &crate::NoProgress);
        let total: f64 = set.vpls.iter().map(|v| v.flux[0] as f64).sum();
        let a = size as f64;
        let omega = 4.0 * (a * a / (a * a + (h * h) as f64)).asin();
        let expected = rho as f64 * intensity as f64 * omega;
        println!("{} VPLs from {} texels: flux {total:.5}, rho I Omega {expected:.5}", set.vpls.len(), set.particles);
        assert!((total / expected - 1.0).abs() < 5e-3, "{total} vs {expected}");
        assert!(set.vpls.iter().all(|v| v.bounce == 1 && (v.position[1]).abs() < 1e-5), "VPLs lie on the plane");
        let paths: Vec<u32> = set.vpls.iter().map(|v| v.path).collect();
        assert!(paths.windows(2).all(|w| w[0] < w[1]), "VPLs in texel order");
        assert!(omega / (4.0 * PI) < 0.5);
    }
}
