//! Stage 2, `shading_points`: one primary ray per camera sample. Sample `s` of pixel `p` is
//! shading point `p * spp + s`; with `spp = 1` it goes through the pixel centre, otherwise it is
//! jittered with the stream (seed, `Stream::Camera`, shading-point index), and its emission is
//! the pixel's, estimated from [`EMISSION_STRATA`]² stratified rays drawn next from that stream.
//!
//! Each ray, those rays included, follows mirrors and glass ([`camera_path`]) to the first
//! surface that is neither, so clustering, visibility and shading never see a specular surface.

use crate::{CpuScene, SurfaceHit};
use glam::Vec3;
use rayon::prelude::*;
use vplgi_shared::bsdf::Transport;
use vplgi_types::params::EMISSION_STRATA;
use vplgi_types::{CameraParams, Rng, ShadingPoint, Stream, MISS};

pub fn shading_points(cs: &CpuScene, camera: &CameraParams) -> Vec<ShadingPoint> {
    shading_points_of(cs, camera, 0..camera.width * camera.height * camera.spp)
}

/// Where a camera ray ends up after the mirrors and glass it meets.
#[derive(Clone, Copy, Debug)]
pub struct CameraPath {
    /// The surface that becomes the shading point; `None` when the chain left the scene.
    pub hit: Option<SurfaceHit>,
    /// The product of the specular vertices' sample weights: each vertex's reflectance for a
    /// mirror, and for glass, chosen with the Fresnel probability, 1 for a reflection and η²
    /// for a refraction (radiance scales by the squared ratio of indices, Mitsuba's
    /// radiance-mode convention).
    pub throughput: Vec3,
    /// The emission seen along the chain, each surface's times the throughput in front of it,
    /// the last surface's included.
    pub emitted: Vec3,
    /// Specular vertices passed.
    pub specular: u32,
    /// Unit direction from the last surface back along the ray that reached it.
    pub view: Vec3,
}

/// Follows the ray `origin + t dir` through at most `depth` specular vertices: at a mirror or
/// glass it continues along the direction the surface's BSDF samples, reflection or refraction
/// chosen by Fresnel with one number from `rng`, and stops at the first other surface (or at
/// the surface after the `depth`-th vertex, whatever it is).
pub fn camera_path(cs: &CpuScene, origin: Vec3, dir: Vec3, depth: u32, rng: &mut Rng) -> CameraPath {
    let mut path = CameraPath { hit: None, throughput: Vec3::ONE, emitted: Vec3::ZERO, specular: 0, view: -dir };
    let (mut origin, mut dir) = (origin, dir);
    while let Some(hit) = cs.trace(origin, dir) {
        path.emitted += path.throughput * hit.emitted;
        path.view = -dir;
        if path.specular == depth || !hit.bsdf().is_specular() {
            path.hit = Some(hit);
            return path;
        }
        let Some((out, weight)) = hit.scatter_specular(dir, rng.next_f32(), Transport::Radiance) else {
            return path;
        };
        path.throughput *= weight;
        path.specular += 1;
        dir = out;
        origin = cs.offset_toward(hit.position, hit.ng, hit.position + dir);
    }
    path
}

/// The shading points of samples `samples` only (a tile of the image); each is the same as in
/// the whole frame.
pub fn shading_points_of(cs: &CpuScene, params: &CameraParams, samples: std::ops::Range<u32>) -> Vec<ShadingPoint> {
    let CameraParams { camera, width, spp, seed, specular_depth, .. } = *params;
    samples
        .into_par_iter()
        .map(|i| {
            let pixel = i / spp;
            let (x, y) = ((pixel % width) as f32, (pixel / width) as f32);
            let (dir, mut jitter) = sample_ray(params, i);
            let mut chain = Rng::new(seed, Stream::Specular, i);
            let path = camera_path(cs, camera.position, dir, specular_depth, &mut chain);
            // A miss carries its pixel's emission too: the pixel may see an emitter's edge
            // against the background, and dropping it there would bias the pixel dark.
            let emitted = match jitter.as_mut() {
                Some(rng) => pixel_emission(cs, params, (x, y), rng, &mut chain),
                None => path.emitted,
            };
            match path.hit {
                Some(h) => ShadingPoint {
                    position: h.position.to_array(),
                    pixel,
                    normal: h.ns.to_array(),
                    triangle: h.triangle,
                    albedo: (path.throughput * h.albedo).to_array(),
                    specular: path.specular,
                    emitted: emitted.to_array(),
                    view: path.view.to_array(),
                    material: h.material,
                    ..Default::default()
                },
                None => ShadingPoint {
                    pixel,
                    triangle: MISS,
                    specular: path.specular,
                    emitted: emitted.to_array(),
                    ..Default::default()
                },
            }
        })
        .collect()
}

/// Sample `i`'s camera ray direction (from `params.camera.position`), and at spp > 1 its jitter
/// stream, left where the pixel's emission rays draw next.
pub fn sample_ray(params: &CameraParams, i: u32) -> (Vec3, Option<Rng>) {
    let CameraParams { camera, width, height, spp, seed, .. } = *params;
    let pixel = i / spp;
    let (x, y) = ((pixel % width) as f32, (pixel / width) as f32);
    let mut jitter = (spp != 1).then(|| Rng::new(seed, Stream::Camera, i));
    let (sx, sy) = match jitter.as_mut() {
        Some(rng) => (x + rng.next_f32(), y + rng.next_f32()),
        None => (x + 0.5, y + 0.5),
    };
    (camera.ray_direction(sx, sy, width, height), jitter)
}

/// The emission seen through the pixel whose top-left corner is `(x, y)`: the mean over one ray
/// jittered in each cell of an `EMISSION_STRATA`² grid over the pixel, an unbiased estimate of
/// the pixel's mean with far less variance than one ray where an emitter's edge crosses it. The
/// rays are jittered from `rng` and follow their specular chains with `chain`.
fn pixel_emission(cs: &CpuScene, params: &CameraParams, (x, y): (f32, f32), rng: &mut Rng, chain: &mut Rng) -> Vec3 {
    let CameraParams { camera, width, height, specular_depth, .. } = *params;
    let n = EMISSION_STRATA;
    let cell = 1.0 / n as f32;
    let mut sum = Vec3::ZERO;
    for j in 0..n {
        for i in 0..n {
            let sx = x + (i as f32 + rng.next_f32()) * cell;
            let sy = y + (j as f32 + rng.next_f32()) * cell;
            let dir = camera.ray_direction(sx, sy, width, height);
            sum += camera_path(cs, camera.position, dir, specular_depth, chain).emitted;
        }
    }
    sum / (n * n) as f32
}

impl vplgi_frame::stages::ShadingPoints for CpuScene<'_> {
    fn shading_points(&self, p: &CameraParams, samples: std::ops::Range<u32>) -> Result<Vec<ShadingPoint>, vplgi_frame::FrameError> {
        Ok(shading_points_of(self, p, samples))
    }
}
