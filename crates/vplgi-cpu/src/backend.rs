//! The CPU reference as a [`Backend`]: every stage on host vectors, each a call into its stage
//! module. The frame itself is [`vplgi_frame::render`].

use crate::bias_points::bias_points;
use crate::cluster::{cluster_from, Clustering};
use crate::gather_radius::gather_radius;
use crate::interpolate::IrradianceSamples;
use crate::rsm_cluster::rsm_cluster_from;
use crate::rsm_importance::rsm_importance;
use crate::rsm_vpls::rsm_vpls;
use crate::seeding::{seeding, ImageHits};
use crate::shade::{sample_irradiance, shade, vpl_lights, VisibilitySource, VplLight, VplLights};
use crate::shading_points::shading_points_of;
use crate::trace_vpls::trace_vpls;
use crate::visibility::{visibility, BitMatrix, Endpoint};
use crate::CpuScene;
use glam::Vec3;
use std::ops::Range;
use vplgi_frame::{Backend, ClusterCounts, FrameError, LightSet, Progress, RsmStart, SampleChunk, ShadeInput, ShadeVisibility, VplCounts};
use vplgi_types::clustering::Centre;
use vplgi_types::clustering::{ClusterParams, ClusterStart, Metric};
use vplgi_types::interpolation::GatherParams;
use vplgi_types::rsm::{RsmCentre, RsmClusterParams};
use vplgi_types::seeding::SeedParams;
use vplgi_types::{BiasParams, Camera, CameraParams, LightShape, ShadeParams, ShadingPoint, TraceParams, Vpl, MISS};

/// The hits of a frame: each hit's sample, each sample's row (or [`MISS`]) and the hits as
/// surface points.
pub struct CpuHits {
    samples: Vec<u32>,
    row_of: Vec<u32>,
    points: Vec<Endpoint>,
}

impl CpuHits {
    /// The G-buffer points of camera samples `samples` (`rsm_importance::pixel_samples`): the
    /// hits among them, in order; a sample that missed gives none.
    pub fn gbuffer_points(&self, samples: &[u32]) -> Vec<Endpoint> {
        samples.iter().filter_map(|&s| self.samples.binary_search(&s).ok().map(|h| self.points[h])).collect()
    }
}

impl Backend for CpuScene<'_> {
    type Error = FrameError;
    type Vpls = Vec<Vpl>;
    type Samples = Vec<ShadingPoint>;
    type Points = Vec<Endpoint>;
    type Hits = CpuHits;
    type Lights = VplLights;
    type Clustering = Clustering;
    type Matrix = BitMatrix;
    type Scalars = Vec<f32>;
    type IrradianceSamples = IrradianceSamples;

    fn scene_extent(&self) -> f32 {
        self.extent
    }

    fn camera(&self) -> Camera {
        self.scene.camera
    }

    fn trace_vpls(&self, p: &TraceParams, progress: &dyn Progress) -> Result<(Vec<Vpl>, VplCounts), FrameError> {
        let set = trace_vpls(self, p.seed, p.count, p.bounces, progress);
        let counts = VplCounts { vpls: set.vpls.len() as u32, particles: set.particles };
        Ok((set.vpls, counts))
    }

    fn rsm_vpls(&self, size: u32, progress: &dyn Progress) -> Result<(Vec<Vpl>, VplCounts), FrameError> {
        let set = rsm_vpls(self, size, progress);
        let counts = VplCounts { vpls: set.vpls.len() as u32, particles: set.particles };
        Ok((set.vpls, counts))
    }

    fn shading_points(&self, p: &CameraParams, samples: Range<u32>) -> Result<Vec<ShadingPoint>, FrameError> {
        Ok(shading_points_of(self, p, samples))
    }

    fn compact_hits(&self, chunks: &[SampleChunk<Vec<ShadingPoint>>], n_samples: u32) -> Result<(CpuHits, u32), FrameError> {
        let mut hits = CpuHits { samples: Vec::new(), row_of: vec![MISS; n_samples as usize], points: Vec::new() };
        for chunk in chunks {
            for (i, sp) in (chunk.first..).zip(&chunk.samples) {
                if !sp.is_miss() {
                    hits.row_of[i as usize] = hits.samples.len() as u32;
                    hits.samples.push(i);
                    hits.points.push(Endpoint::of(sp));
                }
            }
        }
        let n = hits.samples.len() as u32;
        Ok((hits, n))
    }

    fn hits_before(&self, hits: &CpuHits, sample: u32) -> Result<u32, FrameError> {
        Ok(hits.samples.partition_point(|&s| s < sample) as u32)
    }

    fn hit_points<'h>(&self, hits: &'h CpuHits) -> &'h Vec<Endpoint> {
        &hits.points
    }

    fn vpl_points(&self, vpls: &Vec<Vpl>, _n: u32) -> Result<Vec<Endpoint>, FrameError> {
        Ok(vpls.iter().map(Endpoint::of_vpl).collect())
    }

    fn cluster(&self, points: &Vec<Endpoint>, _n: u32, params: &ClusterParams, start: ClusterStart<'_>) -> Result<(Clustering, ClusterCounts), FrameError> {
        let pos: Vec<Vec3> = points.iter().map(Endpoint::p).collect();
        let nor: Vec<Vec3> = points.iter().map(Endpoint::n).collect();
        let c = cluster_from(&pos, &nor, params, start);
        let counts = ClusterCounts { k: c.k() as u32, widened: c.widened as u32, kept: c.kept as u32, fresh: c.fresh as u32 };
        Ok((c, counts))
    }

    fn cluster_centres(&self, c: &Clustering, _k: u32, points: &Vec<Endpoint>, _n: u32, metric: Metric) -> Result<Vec<Centre>, FrameError> {
        let pos: Vec<Vec3> = points.iter().map(Endpoint::p).collect();
        let nor: Vec<Vec3> = points.iter().map(Endpoint::n).collect();
        Ok(crate::cluster::temporal::centres(c, &pos, &nor, metric))
    }

    fn seeding(&self, hits: &CpuHits, _n: u32, camera: &CameraParams, params: &SeedParams) -> Result<Vec<u32>, FrameError> {
        let pos: Vec<Vec3> = hits.points.iter().map(Endpoint::p).collect();
        let nor: Vec<Vec3> = hits.points.iter().map(Endpoint::n).collect();
        // Hits are in sample order: pixel p's are those of samples p spp .. (p + 1) spp.
        let pixels = camera.width as usize * camera.height as usize;
        let pixel_first: Vec<u32> = (0..=pixels).map(|p| hits.samples.partition_point(|&s| (s as usize) < p * camera.spp as usize) as u32).collect();
        let image = ImageHits { positions: &pos, normals: &nor, pixel_first: &pixel_first, width: camera.width, height: camera.height };
        Ok(seeding(&image, params))
    }

    fn rsm_importance(&self, vpls: &Vec<Vpl>, n: u32, rsm_size: u32, hits: &CpuHits, samples: &[u32], d_min: f32) -> Result<Vec<f32>, FrameError> {
        let points = hits.gbuffer_points(samples);
        Ok(rsm_importance(&vpls[..n as usize], &self.lights.rsm_maps(rsm_size), &points, d_min))
    }

    fn rsm_cluster(
        &self,
        vpls: &Vec<Vpl>,
        n: u32,
        rsm_size: u32,
        params: &RsmClusterParams,
        start: RsmStart<'_, Vec<f32>>,
    ) -> Result<(Clustering, ClusterCounts, Vec<RsmCentre>), FrameError> {
        let r = rsm_cluster_from(&vpls[..n as usize], &self.lights.rsm_maps(rsm_size), params, start.importance.map(|i| &i[..]), start.previous);
        let counts = ClusterCounts { k: r.clustering.k() as u32, kept: r.kept, fresh: r.fresh, ..Default::default() };
        Ok((r.clustering, counts, if start.carry { r.centres } else { Vec::new() }))
    }

    fn representatives(&self, c: &Clustering, _k: u32, points: &Vec<Endpoint>, _n: u32) -> Result<Vec<Endpoint>, FrameError> {
        Ok(c.representatives.iter().map(|&r| points[r as usize]).collect())
    }

    fn vpl_lights(&self, vpls: &Vec<Vpl>, n: u32, set: LightSet<'_, Clustering>) -> Result<VplLights, FrameError> {
        let vpls = &vpls[..n as usize];
        Ok(match set {
            LightSet::Clusters { clusters, shape, .. } => vpl_lights(vpls, Some(clusters), shape),
            LightSet::EachVpl { max_bounce } => {
                let mut lights = vpl_lights(vpls, None, LightShape::Point);
                for (l, v) in lights.lights.iter_mut().zip(vpls) {
                    if v.bounce > max_bounce {
                        l.flux = [0.0; 3];
                    }
                }
                lights
            }
        })
    }

    fn light_points(&self, lights: &VplLights, _n: u32) -> Result<Vec<Endpoint>, FrameError> {
        Ok(lights.lights.iter().map(VplLight::endpoint).collect())
    }

    fn visibility(
        &self,
        row_points: &Vec<Endpoint>,
        _n_rows: u32,
        rows: Range<u32>,
        cols: &Vec<Endpoint>,
        _n_cols: u32,
        progress: &dyn Progress,
    ) -> Result<(BitMatrix, Option<u64>), FrameError> {
        let (m, rays) = visibility(self, &row_points[rows.start as usize..rows.end as usize], cols, progress);
        Ok((m, Some(rays)))
    }

    fn shade(&self, input: &ShadeInput<'_, Self>, pixels: Range<u32>, params: &ShadeParams) -> Result<Vec<[f32; 3]>, FrameError> {
        let (matrix, row_of) = (input.matrix, &input.hits.row_of[..]);
        let src = match input.visibility {
            ShadeVisibility::Own { first_row } => VisibilitySource::Own { matrix, row_of, first_row },
            ShadeVisibility::Fuzzy { clustering: c, .. } => VisibilitySource::Fuzzy { matrix, row_of, labels: &c.labels, weights: &c.weights, f: c.f },
            ShadeVisibility::Interpolated { clustering: c, samples, .. } => VisibilitySource::Interpolated { row_of, labels: &c.labels, f: c.f, samples },
        };
        let pixels = pixels.start as usize..pixels.end as usize;
        Ok(shade(self, &input.chunk.samples, input.chunk.first as usize, pixels, input.lights, &src, params))
    }

    fn gather_radius(&self, points: &Vec<Endpoint>, _n: u32, params: &GatherParams) -> Result<Vec<f32>, FrameError> {
        Ok(gather_radius(self, points, params))
    }

    fn sample_irradiance(
        &self,
        points: Vec<Endpoint>,
        _n: u32,
        inv_radius: Vec<f32>,
        lights: &VplLights,
        _n_lights: u32,
        matrix: &BitMatrix,
        g_max: f32,
    ) -> Result<IrradianceSamples, FrameError> {
        let irradiance = sample_irradiance(&points, lights, matrix, g_max);
        Ok(IrradianceSamples { points, inv_radius, irradiance })
    }

    fn bias_points(&self, parent: &Vec<ShadingPoint>, samples: Range<u32>, params: &BiasParams) -> Result<Vec<ShadingPoint>, FrameError> {
        Ok(bias_points(self, parent, samples.start, params))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The G-buffer points are the listed samples' hits, in the list's order; samples that
    /// missed give none.
    #[test]
    fn gbuffer_points_are_the_hits_of_the_listed_samples() {
        let p = |x: f32| Endpoint::new(Vec3::new(x, 0.0, 0.0), Vec3::Y);
        let hits = CpuHits { samples: vec![2, 5, 7], row_of: vec![MISS, MISS, 0, MISS, MISS, 1, MISS, 2], points: vec![p(2.0), p(5.0), p(7.0)] };
        assert_eq!(hits.gbuffer_points(&[7, 3, 5, 0]), vec![p(7.0), p(5.0)]);
        assert!(hits.gbuffer_points(&[1, 4]).is_empty());
    }
}
