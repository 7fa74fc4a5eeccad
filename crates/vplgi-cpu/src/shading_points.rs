//! Stage 2, `shading_points`: one primary ray per camera sample. Sample `s` of pixel `p` is
//! shading point `p * spp + s`; with `spp = 1` it goes through the pixel centre, otherwise it is
//! jittered with the stream (seed, `Stream::Camera`, shading-point index).

use crate::CpuScene;
use rayon::prelude::*;
use vplgi_types::{CameraParams, Rng, ShadingPoint, Stream, MISS};

/// The film position (pixels, origin top-left) of shading point `index`.
pub fn film_position(index: u32, width: u32, spp: u32, seed: u32) -> (f32, f32) {
    let pixel = index / spp;
    let (x, y) = ((pixel % width) as f32, (pixel / width) as f32);
    if spp == 1 {
        (x + 0.5, y + 0.5)
    } else {
        let mut rng = Rng::new(seed, Stream::Camera, index);
        (x + rng.next_f32(), y + rng.next_f32())
    }
}

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
            let (sx, sy) = film_position(i, width, spp, seed);
            let dir = camera.ray_direction(sx, sy, width, height);
            match cs.trace(camera.position, dir) {
                Some(h) => ShadingPoint {
                    position: h.position.to_array(),
                    pixel: i / spp,
                    normal: h.ns.to_array(),
                    triangle: h.triangle,
                    albedo: h.albedo.to_array(),
                    _pad0: 0,
                    emitted: h.emitted.to_array(),
                    _pad1: 0,
                },
                None => ShadingPoint { pixel: i / spp, triangle: MISS, ..Default::default() },
            }
        })
        .collect()
}
