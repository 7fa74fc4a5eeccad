//! The CPU reference's storage for a frame (host vectors) and the glue between its stages. Each
//! stage implements its trait of [`vplgi_frame::stages`] in its own module; the frame itself is
//! [`vplgi_frame::render`].

use crate::caustics::PhotonMap;
use crate::cluster::Clustering;
use crate::interpolate::IrradianceSamples;
use crate::shade::{vpl_lights, VplLight, VplLights};
use crate::visibility::{BitMatrix, Endpoint};
use crate::CpuScene;
use vplgi_frame::{Counted, FrameError, LightSet, SampleChunk, Storage};
use vplgi_types::{Camera, LightShape, ShadingPoint, Vpl, MISS};

/// The hits of a frame: each hit's sample, each sample's row (or [`MISS`]) and the hits as
/// surface points.
pub struct CpuHits {
    pub(crate) samples: Vec<u32>,
    row_of: Vec<u32>,
    pub(crate) points: Vec<Endpoint>,
}

impl CpuHits {
    /// The G-buffer points of camera samples `samples` (`rsm_importance::pixel_samples`): the
    /// hits among them, in order; a sample that missed gives none.
    pub fn gbuffer_points(&self, samples: &[u32]) -> Vec<Endpoint> {
        samples
            .iter()
            .filter_map(|&s| self.samples.binary_search(&s).ok().map(|h| self.points[h]))
            .collect()
    }

    /// Each camera sample's hit number, or [`MISS`].
    pub fn row_of(&self) -> &[u32] {
        &self.row_of
    }
}

impl Counted for CpuHits {
    fn count(&self) -> u32 {
        self.samples.len() as u32
    }
}

impl Storage for CpuScene<'_> {
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
    type PhotonMap = PhotonMap;
    type Cut = vplgi_shared::illumination_cut::GatherCut;

    fn scene_extent(&self) -> f32 {
        self.extent
    }

    fn camera(&self) -> Camera {
        self.scene.camera
    }

    fn has_glossy(&self) -> bool {
        self.scene.materials.iter().any(|m| m.surface.is_glossy())
    }

    fn has_specular(&self) -> bool {
        self.scene.has_specular()
    }

    fn compact_hits(
        &self,
        chunks: &[SampleChunk<Vec<ShadingPoint>>],
        n_samples: u32,
    ) -> Result<CpuHits, FrameError> {
        let mut hits = CpuHits {
            samples: Vec::new(),
            row_of: vec![MISS; n_samples as usize],
            points: Vec::new(),
        };
        for chunk in chunks {
            for (i, sp) in (chunk.first..).zip(&chunk.samples) {
                if !sp.is_miss() {
                    hits.row_of[i as usize] = hits.samples.len() as u32;
                    hits.samples.push(i);
                    hits.points.push(Endpoint::of(sp));
                }
            }
        }
        Ok(hits)
    }

    fn hits_before(&self, hits: &CpuHits, sample: u32) -> Result<u32, FrameError> {
        Ok(hits.samples.partition_point(|&s| s < sample) as u32)
    }

    fn hit_points<'h>(&self, hits: &'h CpuHits) -> &'h Vec<Endpoint> {
        &hits.points
    }

    fn vpl_points(&self, vpls: &Vec<Vpl>) -> Result<Vec<Endpoint>, FrameError> {
        Ok(vpls.iter().map(Endpoint::of_vpl).collect())
    }

    fn vpl_lights(
        &self,
        vpls: &Vec<Vpl>,
        set: LightSet<'_, Clustering>,
    ) -> Result<VplLights, FrameError> {
        Ok(match set {
            LightSet::Clusters { clusters, shape } => vpl_lights(vpls, Some(clusters), shape),
            LightSet::EachVpl { max_bounce } => {
                let mut lights = vpl_lights(vpls, None, LightShape::Point);
                for (l, v) in lights.lights.iter_mut().zip(vpls) {
                    if v.bounce > max_bounce {
                        l.flux = [0.0; 3];
                    }
                }
                lights
            }
            LightSet::Nothing => vpl_lights(&[], None, LightShape::Point),
        })
    }

    fn light_points(&self, lights: &VplLights) -> Result<Vec<Endpoint>, FrameError> {
        Ok(lights.lights.iter().map(VplLight::endpoint).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The G-buffer points are the listed samples' hits, in the list's order; samples that
    /// missed give none.
    #[test]
    fn gbuffer_points_are_the_hits_of_the_listed_samples() {
        let p = |x: f32| Endpoint::new(Vec3::new(x, 0.0, 0.0), Vec3::Y);
        let hits = CpuHits {
            samples: vec![2, 5, 7],
            row_of: vec![MISS, MISS, 0, MISS, MISS, 1, MISS, 2],
            points: vec![p(2.0), p(5.0), p(7.0)],
        };
        assert_eq!(hits.gbuffer_points(&[7, 3, 5, 0]), vec![p(7.0), p(5.0)]);
        assert!(hits.gbuffer_points(&[1, 4]).is_empty());
    }
}
