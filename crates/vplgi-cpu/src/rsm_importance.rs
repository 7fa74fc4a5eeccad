//! The bidirectional importance map of the RSM clustering (`rsm_importance`, Prutkin et al. 2012,
//! Alg. 1 lines 2-4), the CPU reference: each texel's VPL weighted by the geometry terms toward
//! [`rsm_importance::PIXELS`] G-buffer points (`vplgi_shared::rsm_importance`; the backend takes them
//! from its hits, `CpuHits::gbuffer_points`).

use rayon::prelude::*;
use vplgi_shared::rsm::{self, RsmLight};
use vplgi_shared::rsm_importance;
use vplgi_types::{Endpoint, Vpl};
use crate::backend::CpuHits;
use crate::CpuScene;
use vplgi_frame::FrameError;

/// The importance of every texel of `maps` (texel order; 0 where no VPL is) for the VPLs `vpls`
/// seen from `points`, their distances floored at `d_min`.
pub fn rsm_importance(vpls: &[Vpl], maps: &[RsmLight], points: &[Endpoint], d_min: f32) -> Vec<f32> {
    let mut out = vec![0.0f32; rsm::texel_count(maps) as usize];
    let d_min2 = d_min * d_min;
    let values: Vec<(u32, f32)> = vpls.par_iter().map(|v| (v.path, rsm_importance::importance(v, points, d_min2))).collect();
    for (t, x) in values {
        out[t as usize] = x;
    }
    out
}

impl vplgi_frame::stages::RsmImportance for CpuScene<'_> {
    fn rsm_importance(&self, vpls: &Vec<Vpl>, rsm_size: u32, hits: &CpuHits, samples: &[u32], d_min: f32) -> Result<Vec<f32>, FrameError> {
        let points = hits.gbuffer_points(samples);
        Ok(rsm_importance(vpls, &self.lights.rsm_maps(rsm_size), &points, d_min))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Against the definition summed in f64: the texels of two VPLs on a floor, seen from three
    /// points on a wall and one behind the floor.
    #[test]
    fn importance_is_the_flux_times_the_summed_geometry_terms() {
        let map = RsmLight { size: 2, ..rsm::point(Vec3::ZERO, Vec3::ONE) };
        let vpl = |t: u32, x: f32| Vpl { position: [x, 0.0, 0.0], path: t, normal: [0.0, 1.0, 0.0], bounce: 1, flux: [1.0, 0.5, 0.5], specular: 0, ..Default::default() };
        let vpls = [vpl(1, 0.0), vpl(3, 0.5)];
        let points = [
            Endpoint::new(Vec3::new(1.0, 1.0, 0.0), Vec3::NEG_X),
            Endpoint::new(Vec3::new(1.0, 0.5, 0.3), Vec3::NEG_X),
            Endpoint::new(Vec3::new(1.0, 0.01, 0.0), Vec3::NEG_X),
            Endpoint::new(Vec3::new(0.0, -1.0, 0.0), Vec3::Y),
        ];
        let d_min = 0.1f32;
        let got = rsm_importance(&vpls, &[map], &points, d_min);
        assert_eq!((got[0], got[2]), (0.0, 0.0), "texels without a VPL");
        for v in &vpls {
            let mut g = 0.0f64;
            for p in &points {
                let d: Vec<f64> = (0..3).map(|a| p.position[a] as f64 - v.position[a] as f64).collect();
                let d2: f64 = d.iter().map(|x| x * x).sum();
                let len = d2.sqrt();
                let cos_v = (d[1] / len).max(0.0);
                let cos_p = (-(p.normal[0] as f64 * d[0] + p.normal[1] as f64 * d[1] + p.normal[2] as f64 * d[2]) / len).max(0.0);
                g += cos_v * cos_p / d2.max((d_min * d_min) as f64);
            }
            let want = g * 2.0;
            let x = got[v.path as usize] as f64;
            assert!((x - want).abs() <= 1e-6 * want, "texel {}: {x} vs {want}", v.path);
        }
    }
}
