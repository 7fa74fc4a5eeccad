//! Stage 1 with `--vpl-source rsm`, `rsm_vpls`: a reflective shadow map per light (Prutkin et
//! al. 2012, after Dachsbacher and Stamminger 2005), each texel whose ray hits a surface a VPL
//! there, its flux the texel's power times the albedo (`vplgi_shared::rsm`). One bounce only.
//!
//! Texel t's ray is a pure function of the maps and t, so the VPLs, in texel order with `path` =
//! t, do not depend on threads; a texel whose ray escapes (or a spot texel outside the outer
//! cone) leaves no VPL. No normalisation follows: the texels' powers already sum to the lights'.

use crate::trace_vpls::VplSet;
use crate::CpuScene;
use rayon::prelude::*;
use vplgi_frame::Progress;
use vplgi_shared::rsm::{self, RsmLight};
use vplgi_types::Vpl;
use vplgi_frame::FrameError;

/// The VPL of texel `t` of `maps`, if its ray hits a surface.
pub fn texel_vpl(cs: &CpuScene, maps: &[RsmLight], t: u32) -> Option<Vpl> {
    let ray = rsm::texel_ray(&maps[rsm::map_of(maps, t)], t)?;
    let hit = cs.trace(ray.origin + ray.surface_normal * cs.eps, ray.dir)?;
    let flux = ray.power * hit.albedo;
    Some(Vpl { position: hit.position.to_array(), path: t, normal: hit.ns.to_array(), bounce: 1, flux: flux.to_array(), specular: 0 })
}

/// The VPLs of the maps of every light of the scene for a budget of about `size²` texels.
pub fn rsm_vpls(cs: &CpuScene, size: u32, progress: &dyn Progress) -> VplSet {
    let maps = cs.lights.rsm_maps(size);
    let texels = rsm::texel_count(&maps);
    progress.start("rsm_vpls", 1);
    let vpls: Vec<Vpl> = (0..texels).into_par_iter().filter_map(|t| texel_vpl(cs, &maps, t)).collect();
    progress.finish();
    VplSet { vpls, particles: texels }
}

impl vplgi_frame::stages::RsmVpls for CpuScene<'_> {
    fn rsm_vpls(&self, size: u32, progress: &dyn Progress) -> Result<(Vec<Vpl>, u32), FrameError> {
        let set = rsm_vpls(self, size, progress);
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
        let set = rsm_vpls(&cs, 512, &crate::NoProgress);
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
