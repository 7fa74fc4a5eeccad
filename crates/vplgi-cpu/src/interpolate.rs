//! Stage `interpolate` (`--shade interpolate`, Wang et al. 2009, section 3.4): irradiance from the
//! VPL lights at the sample points only, each a shading-point cluster's representative with its
//! own visibility row (`shade::sample_irradiance`, shade's own sums), then at every shading point
//! the irradiance-caching interpolation of its F nearest clusters' samples
//! (`vplgi_types::interpolation`), here. Where fuzzy visibility sums every
//! light at every shading point, this sums them at K points and costs F weights per shading
//! point.

use glam::Vec3;
use vplgi_types::interpolation::weight;
use vplgi_types::{Endpoint, MISS};
use crate::shade::{sample_irradiance, Receiver, VplLights};
use vplgi_shared::sh::{glossy_irradiance, ShRgb};
use vplgi_types::params::SH_COEFFICIENTS;
use crate::visibility::BitMatrix;
use crate::CpuScene;
use vplgi_frame::FrameError;

/// The sample points of a frame: where they are, their 1 / R_j (from their gather rays), the
/// irradiance there, and, from the final gather of `--gi photon`, the spherical harmonics of
/// their incident light (`vplgi_shared::sh`; empty for the VPL lights' samples).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IrradianceSamples {
    pub points: Vec<Endpoint>,
    pub inv_radius: Vec<f32>,
    pub irradiance: Vec<[f32; 3]>,
    pub sh: Vec<ShRgb>,
}

/// The irradiance at `p` (normal `n`) interpolated from the sample points of clusters `labels`
/// (missing ones are [`MISS`]): Σ w E / Σ w in label order, 0 if no cluster is left. At a
/// glossy `receiver`, where the samples carry spherical harmonics, the coefficients are
/// interpolated with the same weights and integrated against its lobe
/// (`vplgi_shared::sh::glossy_irradiance`), so that ρ / π times the result is still the
/// reflected radiance.
pub fn interpolate(p: Vec3, n: Vec3, receiver: Receiver, labels: &[u32], samples: &IrradianceSamples) -> Vec3 {
    let glossy = receiver.filter(|_| !samples.sh.is_empty());
    let (mut sum, mut total) = (Vec3::ZERO, 0.0f32);
    let mut sh = [[0.0f32; 3]; SH_COEFFICIENTS];
    for &k in labels.iter().filter(|&&k| k != MISS) {
        let s = &samples.points[k as usize];
        let d = s.p() - p;
        let w = weight(d.dot(d), n.dot(s.n()), samples.inv_radius[k as usize]);
        sum += Vec3::from(samples.irradiance[k as usize]) * w;
        total += w;
        if glossy.is_some() {
            for (acc, c) in sh.iter_mut().zip(&samples.sh[k as usize]) {
                *acc = (Vec3::from(*acc) + Vec3::from(*c) * w).to_array();
            }
        }
    }
    if total <= 0.0 {
        return Vec3::ZERO;
    }
    let e = sum / total;
    match glossy {
        Some((surface, view)) => {
            for acc in sh.iter_mut() {
                *acc = (Vec3::from(*acc) / total).to_array();
            }
            glossy_irradiance(&sh, e, surface, n, view)
        }
        None => e,
    }
}

impl vplgi_frame::stages::Interpolate for CpuScene<'_> {
    fn sample_irradiance(&self, points: Vec<Endpoint>, inv_radius: Vec<f32>, lights: &VplLights, matrix: &BitMatrix, g_max: f32) -> Result<IrradianceSamples, FrameError> {
        let irradiance = sample_irradiance(&self.scene.materials, &points, lights, matrix, g_max);
        Ok(IrradianceSamples { points, inv_radius, irradiance, sh: Vec::new() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(points: &[(Vec3, Vec3)], inv_radius: &[f32], irradiance: &[f32]) -> IrradianceSamples {
        IrradianceSamples {
            points: points.iter().map(|&(p, n)| Endpoint::new(p, n)).collect(),
            inv_radius: inv_radius.to_vec(),
            irradiance: irradiance.iter().map(|&e| [e, 2.0 * e, 0.0]).collect(),
            sh: Vec::new(),
        }
    }

    /// Two samples by hand. The shading point is at the origin facing +z. Sample 0 is 3 units
    /// away with R = 2 and the same normal: error 1.5, weight 2/3. Sample 1 is 1 unit away with
    /// R = 4 and a normal turned by 60°: error 0.25 + 1, weight 0.8. So E = (2/3 · 10 + 0.8 · 1)
    /// / (2/3 + 0.8) = 7.4667 / 1.4667 = 5.0909...
    #[test]
    fn two_samples_by_hand() {
        let turned = Vec3::new(3f32.sqrt() / 2.0, 0.0, 0.5);
        let s = samples(&[(Vec3::new(3.0, 0.0, 0.0), Vec3::Z), (Vec3::new(0.0, 1.0, 0.0), turned)], &[0.5, 0.25], &[10.0, 1.0]);
        let e = interpolate(Vec3::ZERO, Vec3::Z, None, &[0, 1], &s);
        let exact = (2.0 / 3.0 * 10.0 + 0.8) / (2.0 / 3.0 + 0.8);
        assert!((e.x - exact).abs() < 1e-5 && (e.y - 2.0 * exact).abs() < 1e-5 && e.z == 0.0, "{e} vs {exact}");
        // A missing cluster takes no part; none at all gives 0, not a NaN.
        assert_eq!(interpolate(Vec3::ZERO, Vec3::Z, None, &[MISS, 0], &s), Vec3::new(10.0, 20.0, 0.0));
        assert_eq!(interpolate(Vec3::ZERO, Vec3::Z, None, &[MISS, MISS], &s), Vec3::ZERO);
    }

    /// A shading point on its own sample point takes that sample's value (to within the
    /// MIN_ERROR floor's 1e-4 share of the others).
    #[test]
    fn a_sample_point_keeps_its_own_value() {
        let s = samples(&[(Vec3::ZERO, Vec3::Z), (Vec3::X, Vec3::Z)], &[1.0, 1.0], &[5.0, 100.0]);
        let e = interpolate(Vec3::ZERO, Vec3::Z, None, &[1, 0], &s);
        assert!((e.x / 5.0 - 1.0).abs() < 3e-3, "{e}");
    }
}
