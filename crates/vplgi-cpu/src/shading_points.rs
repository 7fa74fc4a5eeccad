//! Stage 2, `shading_points`: one primary ray per camera sample. Sample `s` of pixel `p` is
//! shading point `p * spp + s`; with `spp = 1` it goes through the pixel centre, otherwise it is
//! jittered with the stream (seed, `Stream::Camera`, shading-point index), and its emission is
//! the pixel's, estimated from [`EMISSION_STRATA`]² stratified rays drawn next from that stream.

use crate::CpuScene;
use glam::Vec3;
use rayon::prelude::*;
use vplgi_types::params::EMISSION_STRATA;
use vplgi_types::{Camera, CameraParams, Rng, ShadingPoint, Stream, MISS};

pub fn shading_points(cs: &CpuScene, width: u32, height: u32, spp: u32, seed: u32) -> Vec<ShadingPoint> {
    shading_points_of(cs, &CameraParams { camera: cs.scene.camera, width, height, spp, seed }, 0..width * height * spp)
}

/// The shading points of samples `samples` only (a tile of the image); each is the same as in
/// the whole frame.
pub fn shading_points_of(cs: &CpuScene, params: &CameraParams, samples: std::ops::Range<u32>) -> Vec<ShadingPoint> {
    let CameraParams { camera, width, height, spp, seed } = *params;
    samples
        .into_par_iter()
        .map(|i| {
            let pixel = i / spp;
            let (x, y) = ((pixel % width) as f32, (pixel / width) as f32);
            let mut jitter = (spp != 1).then(|| Rng::new(seed, Stream::Camera, i));
            let (sx, sy) = match jitter.as_mut() {
                Some(rng) => (x + rng.next_f32(), y + rng.next_f32()),
                None => (x + 0.5, y + 0.5),
            };
            let hit = cs.trace(camera.position, camera.ray_direction(sx, sy, width, height));
            // A miss carries its pixel's emission too: the pixel may see an emitter's edge
            // against the background, and dropping it there would bias the pixel dark.
            let emitted = match (jitter.as_mut(), &hit) {
                (Some(rng), _) => pixel_emission(cs, &camera, (width, height), (x, y), rng),
                (None, Some(h)) => h.emitted,
                (None, None) => Vec3::ZERO,
            };
            match hit {
                Some(h) => ShadingPoint {
                    position: h.position.to_array(),
                    pixel,
                    normal: h.ns.to_array(),
                    triangle: h.triangle,
                    albedo: h.albedo.to_array(),
                    _pad0: 0,
                    emitted: emitted.to_array(),
                    _pad1: 0,
                },
                None => ShadingPoint { pixel, triangle: MISS, emitted: emitted.to_array(), ..Default::default() },
            }
        })
        .collect()
}

/// The emission seen through the pixel whose top-left corner is `(x, y)`: the mean over one ray
/// jittered in each cell of an `EMISSION_STRATA`² grid over the pixel, an unbiased estimate of
/// the pixel's mean with far less variance than one ray where an emitter's edge crosses it.
fn pixel_emission(cs: &CpuScene, camera: &Camera, (width, height): (u32, u32), (x, y): (f32, f32), rng: &mut Rng) -> Vec3 {
    let n = EMISSION_STRATA;
    let cell = 1.0 / n as f32;
    let mut sum = Vec3::ZERO;
    for j in 0..n {
        for i in 0..n {
            let sx = x + (i as f32 + rng.next_f32()) * cell;
            let sy = y + (j as f32 + rng.next_f32()) * cell;
            if let Some(h) = cs.trace(camera.position, camera.ray_direction(sx, sy, width, height)) {
                sum += h.emitted;
            }
        }
    }
    sum / (n * n) as f32
}

impl vplgi_frame::stages::ShadingPoints for CpuScene<'_> {
    fn shading_points(&self, p: &CameraParams, samples: std::ops::Range<u32>) -> Result<Vec<ShadingPoint>, vplgi_frame::FrameError> {
        Ok(shading_points_of(self, p, samples))
    }
}
