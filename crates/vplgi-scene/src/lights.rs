//! Light sources: emissive triangles (area lights) and punctual lights, with the discrete
//! distributions used to pick one. The tables are built once on the host and read by every
//! backend (the GPU uploads them), so all backends choose lights with the same probabilities.
//!
//! Light particles choose among *all* lights in proportion to their power. Direct lighting chooses
//! a group of area lights by what it can contribute at the shading point
//! (`vplgi_types::light_groups`), then an emitter of the group by power, and evaluates every
//! punctual light with one shadow ray each (a punctual light cannot be hit by chance).

use crate::{PunctualLight, Scene};
use glam::Vec3;
use std::f32::consts::PI;
use vplgi_shared::rsm::{self, RsmLight};
use vplgi_types::device::LightGroup;
use vplgi_types::light_groups::{group_importance, ANY_ORIENTATION, MAX_GROUPS};
use vplgi_types::sampling;

/// A discrete distribution over `n` items, sampled by inverting its CDF.
#[derive(Clone, Debug, Default)]
pub struct Distribution {
    cdf: Vec<f32>,
    pmf: Vec<f32>,
}

impl Distribution {
    /// Builds from non-negative weights. Summation is sequential in f64, so the table does not
    /// depend on threads.
    pub fn new(weights: &[f32]) -> Distribution {
        let total: f64 = weights.iter().map(|&w| w.max(0.0) as f64).sum();
        if total <= 0.0 {
            return Distribution::default();
        }
        let mut acc = 0.0f64;
        let mut cdf = Vec::with_capacity(weights.len());
        for &w in weights {
            acc += w.max(0.0) as f64;
            cdf.push((acc / total) as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        // The probability each item is really drawn with: `sample` receives u = k / 2^24
        // (`Rng::next_f32`) and picks the first item whose f32 CDF exceeds u, so item i owns
        // ceil(cdf_i 2^24) - ceil(cdf_{i-1} 2^24) of the 2^24 values. Dividing by this realised
        // probability instead of the exact weight share keeps the estimators unbiased for tiny
        // lights (an item below 2^-24 of the total is never drawn and its energy is lost).
        let grid = |c: f32| (c as f64 * 16_777_216.0).ceil();
        let pmf = (0..cdf.len())
            .map(|i| {
                ((grid(cdf[i]) - if i == 0 { 0.0 } else { grid(cdf[i - 1]) }) / 16_777_216.0) as f32
            })
            .collect();
        Distribution { cdf, pmf }
    }

    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Index `i` with probability `pmf(i)`, for `u` in [0, 1). Items of zero weight are never
    /// returned.
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let i = self.cdf.partition_point(|&c| c <= u).min(self.cdf.len() - 1);
        (i, self.pmf[i])
    }

    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// The CDF table: item i is drawn for u in [cdf[i-1], cdf[i]).
    pub fn cdf(&self) -> &[f32] {
        &self.cdf
    }

    /// The realised probabilities of every item.
    pub fn pmfs(&self) -> &[f32] {
        &self.pmf
    }
}

/// Scalar power used to choose lights: the mean of the RGB power.
fn scalar(p: Vec3) -> f32 {
    (p.x + p.y + p.z) / 3.0
}

/// A light particle leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct Emission {
    pub origin: Vec3,
    pub dir: Vec3,
    /// Power carried, before division by the number of particles.
    pub power: Vec3,
    /// Front normal of the emitting surface (zero for punctual lights): the particle must start
    /// just off it, or its first ray hits the light itself at t = 0.
    pub surface_normal: Vec3,
}

/// A point sampled on an area light for direct lighting.
#[derive(Clone, Copy, Debug)]
pub struct AreaSample {
    pub position: Vec3,
    /// Front normal of the emitting triangle.
    pub normal: Vec3,
    pub radiance: Vec3,
    /// Probability density of the sample with respect to area.
    pub pdf_area: f32,
}

pub struct LightSampler {
    /// Emissive triangles, in triangle order.
    pub emitters: Vec<u32>,
    areas: Vec<f32>,
    /// Over emitters then punctual lights, by power.
    all: Distribution,
    /// Over emitters only, by power.
    area: Distribution,
    punctual: Vec<PunctualLight>,
    /// Runs of consecutive emitters that direct light chooses among (`vplgi_types::light_groups`).
    groups: Vec<LightGroup>,
    /// Total emitted power of every light, RGB (W).
    pub total_power: Vec3,
    /// Each light's reflective shadow map, unsized (emitters then punctual lights), and its
    /// share of the total power (`vplgi_shared::rsm`).
    rsm: Vec<RsmLight>,
    rsm_shares: Vec<f32>,
    /// Where directional lights start.
    pub sun: SunFrame,
}

/// Where a directional light's particles and shadow-map rays start: a disk (or, for the map, the
/// square around it) of the radius of the scene's bounding sphere, perpendicular to the light and
/// touching the sphere on the side the light comes from, so every ray that can reach the scene
/// crosses it and none starts inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SunFrame {
    /// The bounding sphere's centre.
    pub centre: Vec3,
    pub radius: f32,
}

impl SunFrame {
    /// The bounding sphere of the scene's box, widened by 1e-3 so that rounding never puts a
    /// surface outside it.
    pub fn of(scene: &Scene) -> SunFrame {
        let (min, max) = scene.bounds();
        SunFrame { centre: (min + max) * 0.5, radius: (max - min).length() * 0.5 * 1.001 }
    }

    /// The centre of the disk a light travelling along unit `direction` starts from.
    pub fn disk_centre(&self, direction: Vec3) -> Vec3 {
        self.centre - direction * self.radius
    }

    /// Power through the disk from irradiance `irradiance`: E π R².
    pub fn power(&self, irradiance: Vec3) -> Vec3 {
        irradiance * (PI * self.radius * self.radius)
    }
}

/// A uniform point on the disk of radius `radius` around `centre` perpendicular to the unit
/// `axis` (pdf 1 / (π R²)): where a directional light's particle starts.
pub fn sun_origin(centre: Vec3, axis: Vec3, radius: f32, u1: f32, u2: f32) -> Vec3 {
    let r = radius * u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = sampling::orthonormal_basis(axis);
    centre + t * (r * phi.cos()) + b * (r * phi.sin())
}

/// The importances of every light group at one shading point, and their sum: computed once per
/// point, then shared by its direct-light samples.
pub struct GroupChoice {
    weights: [f32; MAX_GROUPS],
    total: f32,
}

/// Cuts emitters (in triangle order) into at most [`MAX_GROUPS`] runs of nearly equal length and
/// bounds each: the sphere around its vertices' box, the cone around its area-weighted normal.
/// Both are widened by 1e-4 so that rounding never excludes a point that can contribute.
fn light_groups(
    scene: &Scene,
    emitters: &[u32],
    areas: &[f32],
    powers: &[f32],
    area: &Distribution,
) -> Vec<LightGroup> {
    let n = emitters.len();
    let count = n.min(MAX_GROUPS);
    (0..count)
        .map(|g| {
            let range = g * n / count..(g + 1) * n / count;
            let tris = || range.clone().map(|e| emitters[e] as usize);
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for t in tris() {
                for v in scene.triangle(t) {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            let centre = (lo + hi) * 0.5;
            let r = tris()
                .flat_map(|t| scene.triangle(t))
                .map(|v| (v - centre).length())
                .fold(0.0f32, f32::max);
            let sum_n = range.clone().fold(Vec3::ZERO, |a, e| {
                a + scene.geometric_normal(emitters[e] as usize) * areas[e]
            });
            let axis = sum_n.normalize_or_zero();
            let cos_n =
                tris().map(|t| axis.dot(scene.geometric_normal(t))).fold(1.0f32, f32::min) - 1e-4;
            let cone = if axis == Vec3::ZERO || cos_n <= 0.0 {
                [0.0, 0.0, 0.0, ANY_ORIENTATION]
            } else {
                [axis.x, axis.y, axis.z, cos_n]
            };
            let pmf: f32 = range.clone().map(|e| area.pmf(e)).sum();
            let before = if range.start == 0 { 0.0 } else { area.cdf()[range.start - 1] };
            LightGroup {
                sphere: [centre.x, centre.y, centre.z, r * (1.0 + 1e-4) + 1e-6],
                cone,
                power: [range.clone().map(|e| powers[e]).sum(), pmf, before, 0.0],
                range: [range.start as u32, range.len() as u32, 0, 0],
            }
        })
        .collect()
}

/// Power of a punctual light: 4 pi I for a point light; for a spot, I times the solid-angle
/// integral of the glTF falloff, 2 pi [(1 - cos_inner) + (cos_inner - cos_outer) / 3]
/// (the quadratic ramp integrates to a third of the ring); for a directional light, what crosses
/// the disk it starts from (`sun`).
pub fn punctual_power(l: &PunctualLight, sun: &SunFrame) -> Vec3 {
    match *l {
        PunctualLight::Point { intensity, .. } => intensity * (4.0 * PI),
        PunctualLight::Spot { intensity, cos_inner, cos_outer, .. } => {
            intensity * (2.0 * PI * ((1.0 - cos_inner) + (cos_inner - cos_outer).max(0.0) / 3.0))
        }
        PunctualLight::Directional { irradiance, .. } => sun.power(irradiance),
    }
}

impl LightSampler {
    pub fn new(scene: &Scene) -> LightSampler {
        let mut emitters = Vec::new();
        let mut areas = Vec::new();
        let mut powers = Vec::new();
        for t in 0..scene.triangle_count() {
            let le = scene.emission(t);
            if scalar(le) > 0.0 {
                let [a, b, c] = scene.triangle(t);
                let area = 0.5 * (b - a).cross(c - a).length();
                if area > 0.0 {
                    emitters.push(t as u32);
                    areas.push(area);
                    // A Lambertian emitter of radiance Le and area A emits pi * A * Le.
                    powers.push(le * (PI * area));
                }
            }
        }
        let area_powers: Vec<f32> = powers.iter().map(|&p| scalar(p)).collect();
        let area = Distribution::new(&area_powers);
        let groups = light_groups(scene, &emitters, &areas, &area_powers, &area);
        let sun = SunFrame::of(scene);
        powers.extend(scene.lights.iter().map(|l| punctual_power(l, &sun)));
        let all = Distribution::new(&powers.iter().map(|&p| scalar(p)).collect::<Vec<_>>());
        let total_power = powers.iter().fold(Vec3::ZERO, |a, &p| a + p);
        let mut rsm: Vec<RsmLight> = emitters
            .iter()
            .map(|&t| {
                let [a, b, c] = scene.triangle(t as usize);
                rsm::area(a, b, c, scene.geometric_normal(t as usize), scene.emission(t as usize))
            })
            .collect();
        rsm.extend(scene.lights.iter().map(|l| match *l {
            PunctualLight::Point { position, intensity } => rsm::point(position, intensity),
            PunctualLight::Spot { position, direction, intensity, cos_inner, cos_outer } => {
                rsm::spot(position, direction, intensity, cos_inner, cos_outer)
            }
            PunctualLight::Directional { direction, irradiance } => {
                rsm::directional(sun.disk_centre(direction), direction, sun.radius, irradiance)
            }
        }));
        let total = scalar(total_power);
        let rsm_shares =
            powers.iter().map(|&p| if total > 0.0 { scalar(p) / total } else { 0.0 }).collect();
        LightSampler {
            emitters,
            areas,
            all,
            area,
            punctual: scene.lights.clone(),
            groups,
            total_power,
            rsm,
            rsm_shares,
            sun,
        }
    }

    /// The reflective shadow maps of every light for a budget of about `size²` texels, sized by
    /// power (`vplgi_shared::rsm::sized`).
    pub fn rsm_maps(&self, size: u32) -> Vec<RsmLight> {
        rsm::sized(&self.rsm, &self.rsm_shares, size)
    }

    pub fn has_lights(&self) -> bool {
        !self.all.is_empty()
    }

    pub fn punctual(&self) -> &[PunctualLight] {
        &self.punctual
    }

    /// Areas of the emitters, in the order of [`LightSampler::emitters`].
    pub fn areas(&self) -> &[f32] {
        &self.areas
    }

    /// The distribution over emitters used for direct light.
    pub fn area_distribution(&self) -> &Distribution {
        &self.area
    }

    /// The distribution over emitters then punctual lights used to start light particles.
    pub fn all_distribution(&self) -> &Distribution {
        &self.all
    }

    /// Starts a light particle from four uniform numbers and a fifth for the light choice.
    /// Returns `None` when the scene has no light.
    pub fn emit(&self, scene: &Scene, u: [f32; 5]) -> Option<Emission> {
        if self.all.is_empty() {
            return None;
        }
        let (i, pmf) = self.all.sample(u[0]);
        if i < self.emitters.len() {
            let t = self.emitters[i] as usize;
            let [a, b, c] = scene.triangle(t);
            let (b1, b2) = sampling::uniform_triangle(u[1], u[2]);
            let n = scene.geometric_normal(t);
            let origin = a + (b - a) * b1 + (c - a) * b2;
            // Position pdf 1/A times cosine pdf cos/pi against Le cos: power = pi A Le.
            let power = scene.emission(t) * (PI * self.areas[i]) / pmf;
            Some(Emission {
                origin,
                dir: sampling::cosine_hemisphere(n, u[3], u[4]),
                power,
                surface_normal: n,
            })
        } else {
            let light = &self.punctual[i - self.emitters.len()];
            match *light {
                PunctualLight::Point { position, intensity } => Some(Emission {
                    origin: position,
                    dir: sampling::uniform_sphere(u[3], u[4]),
                    power: intensity * (4.0 * PI) / pmf,
                    surface_normal: Vec3::ZERO,
                }),
                PunctualLight::Spot { position, direction, intensity, cos_outer, .. } => {
                    let dir = sampling::uniform_cone(direction, cos_outer, u[3], u[4]);
                    let inv_pdf = 2.0 * PI * (1.0 - cos_outer);
                    // The falloff of the sampled cosine, not of the direction built from it: a
                    // narrow ramp between the cones multiplies the direction's rounding by up to
                    // 1,000 (the GPU twin differed by 2e-4 in flux on random spots).
                    let falloff = light.falloff_cos(sampling::uniform_cone_cos(cos_outer, u[3]));
                    Some(Emission {
                        origin: position,
                        dir,
                        power: intensity * (falloff * inv_pdf / pmf),
                        surface_normal: Vec3::ZERO,
                    })
                }
                PunctualLight::Directional { direction, irradiance } => Some(Emission {
                    origin: sun_origin(
                        self.sun.disk_centre(direction),
                        direction,
                        self.sun.radius,
                        u[3],
                        u[4],
                    ),
                    dir: direction,
                    power: self.sun.power(irradiance) / pmf,
                    surface_normal: Vec3::ZERO,
                }),
            }
        }
    }

    /// The light groups direct light chooses among.
    pub fn groups(&self) -> &[LightGroup] {
        &self.groups
    }

    /// Every group's importance at point `p` with unit normal `n`.
    pub fn group_choice(&self, p: Vec3, n: Vec3) -> GroupChoice {
        let mut weights = [0.0f32; MAX_GROUPS];
        let mut total = 0.0f32;
        for (w, g) in weights.iter_mut().zip(&self.groups) {
            *w = group_importance(g, p, n);
            total += *w;
        }
        GroupChoice { weights, total }
    }

    /// A point on an area light for direct light at the point `choice` was made for: a group with
    /// probability importance / total (from `u[0]`, walked in group order), then an emitter of
    /// that group by power (from where `u[0]` fell inside the group's share, so one stratified
    /// number serves both choices), then a uniform point on it. `None` when no group can light
    /// the point.
    pub fn sample_area_at(
        &self,
        scene: &Scene,
        choice: &GroupChoice,
        u: [f32; 3],
    ) -> Option<AreaSample> {
        // Also false for a NaN total.
        if choice.total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let target = u[0] * choice.total;
        let mut acc = 0.0f32;
        let mut chosen = None;
        for (g, &w) in choice.weights[..self.groups.len()].iter().enumerate() {
            if w > 0.0 {
                chosen = Some((g, acc, w));
                if target < acc + w {
                    break;
                }
            }
            acc += w;
        }
        // The last group with weight takes what rounding leaves past the end.
        let (g, before, w) = chosen?;
        let group = &self.groups[g];
        let v = ((target - before) / w).clamp(0.0, 1.0 - 1.0 / 16_777_216.0);
        let first = group.range[0] as usize;
        let last = first + group.range[1] as usize - 1;
        let (i, _) = self.area.sample(group.power[2] + v * group.power[1]);
        let i = i.clamp(first, last);
        let t = self.emitters[i] as usize;
        let [a, b, c] = scene.triangle(t);
        let (b1, b2) = sampling::uniform_triangle(u[1], u[2]);
        Some(AreaSample {
            position: a + (b - a) * b1 + (c - a) * b2,
            normal: scene.geometric_normal(t),
            radiance: scene.emission(t),
            pdf_area: (w / choice.total) * (self.area.pmf(i) / group.power[1]) / self.areas[i],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_follows_weights_and_skips_zeros() {
        let d = Distribution::new(&[1.0, 0.0, 3.0]);
        assert_eq!(d.sample(0.0).0, 0);
        assert_eq!(d.sample(0.2499).0, 0);
        assert_eq!(d.sample(0.25).0, 2);
        assert_eq!(d.sample(0.9999).0, 2);
        assert!((d.pmf(2) - 0.75).abs() < 1e-7);
        assert_eq!(d.pmf(1), 0.0);
        // A tiny item keeps the probability it is really drawn with on the 2^-24 grid.
        let tiny = Distribution::new(&[1.0, 1e-9]);
        let draws =
            (0..1u32 << 24).filter(|&k| tiny.sample(k as f32 / 16_777_216.0).0 == 1).count();
        assert_eq!(tiny.pmf(1), draws as f32 / 16_777_216.0);
        assert!(Distribution::new(&[0.0, 0.0]).is_empty());
    }

    #[test]
    fn spot_power_matches_numerical_integral() {
        let light = PunctualLight::Spot {
            position: Vec3::ZERO,
            direction: Vec3::Z,
            intensity: Vec3::ONE,
            cos_inner: 0.9,
            cos_outer: 0.6,
        };
        // Integrate the falloff over the sphere in cos(theta): dω = 2π d(cos θ).
        let n = 200_000;
        let mut acc = 0.0f64;
        for i in 0..n {
            let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            let s = (1.0 - c * c).sqrt();
            acc += light.falloff(Vec3::new(s as f32, 0.0, c as f32)) as f64;
        }
        let numeric = 2.0 * std::f64::consts::PI * acc * 2.0 / n as f64;
        let analytic = punctual_power(&light, &SunFrame::default()).x as f64;
        assert!((numeric - analytic).abs() < 1e-3 * analytic, "{numeric} vs {analytic}");
    }

    /// More emitters than groups: 70 strips of rising radiance in a row make 32 groups of 2 or 3.
    /// Each emitter must be drawn as often as the probability the estimator divides by, which
    /// exercises the choice inside a group (by power, from the rest of the stratified number).
    #[test]
    fn emitters_inside_groups_are_drawn_as_often_as_their_probability() {
        use crate::{Material, Scene};
        use vplgi_types::{Rng, Stream};
        let mut scene = Scene::default();
        let n = 70;
        for t in 0..n {
            let x = t as f32 * 0.1;
            scene.positions.extend_from_slice(&[
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.1, 0.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            ]);
            scene.normals.extend_from_slice(&[Vec3::Y; 3]);
            scene.uvs.extend_from_slice(&[glam::Vec2::ZERO; 3]);
            let base = 3 * t as u32;
            scene.indices.push([base, base + 2, base + 1]);
            scene.material_ids.push(t as u32);
            scene.materials.push(Material {
                emission: Vec3::splat(1.0 + (t % 7) as f32),
                ..Material::default()
            });
        }
        let sampler = LightSampler::new(&scene);
        assert_eq!(sampler.groups().len(), MAX_GROUPS);
        assert!(sampler.groups().iter().all(|g| (2..=3).contains(&g.range[1])));
        let choice = sampler.group_choice(Vec3::new(2.0, 1.0, 0.5), Vec3::NEG_Y);
        let samples = 200_000;
        let mut counts = vec![0u32; n];
        let mut prob = vec![0.0f64; n];
        let mut rng = Rng::new(6, Stream::Oracle, 0);
        for _ in 0..samples {
            let s = sampler
                .sample_area_at(&scene, &choice, [rng.next_f32(), rng.next_f32(), rng.next_f32()])
                .unwrap();
            let t = ((s.position.x / 0.1).floor() as usize).min(n - 1);
            counts[t] += 1;
            prob[t] = s.pdf_area as f64 * 0.05;
        }
        let total: f64 = prob.iter().sum();
        assert!((total - 1.0).abs() < 1e-4, "probabilities sum to {total}");
        let chi2: f64 = (0..n)
            .map(|t| {
                (counts[t] as f64 - samples as f64 * prob[t]).powi(2) / (samples as f64 * prob[t])
            })
            .sum();
        // 69 degrees of freedom: the 0.999 quantile is 111.
        println!("emitters in groups: chi2 = {chi2:.1} (69 dof, reject above 111)");
        assert!(chi2 < 111.0, "chi2 = {chi2}, counts {counts:?}");
    }

    /// χ² goodness of fit of direct light's area-light sampling at a receiver above two emitters
    /// of different area and radiance, each split into its four midpoint sub-triangles (a quarter
    /// of its area each). An emitter must be drawn as often as the probability the estimator
    /// divides by (pdf × area, the same for all its samples, summing to 1 over emitters), and
    /// positions inside it uniformly.
    #[test]
    fn area_light_sampling_chi2() {
        use crate::{Material, Scene};
        use vplgi_types::{Rng, Stream};
        let mut scene = Scene::default();
        let tris = [
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)],
            [Vec3::new(2.0, 0.0, 0.0), Vec3::new(4.0, 0.0, 0.5), Vec3::new(2.0, 0.0, 3.0)],
        ];
        for (t, tri) in tris.iter().enumerate() {
            scene.positions.extend_from_slice(tri);
            scene.normals.extend_from_slice(&[Vec3::Y; 3]);
            scene.uvs.extend_from_slice(&[glam::Vec2::ZERO; 3]);
            let base = 3 * t as u32;
            scene.indices.push([base, base + 2, base + 1]);
            scene.material_ids.push(t as u32);
            scene.materials.push(Material {
                emission: Vec3::splat(1.0 + 3.0 * t as f32),
                ..Material::default()
            });
        }
        let sampler = LightSampler::new(&scene);
        assert_eq!(sampler.groups().len(), 2, "two emitters, two groups");
        let choice = sampler.group_choice(Vec3::new(0.5, 1.5, 0.5), Vec3::NEG_Y);
        let mut counts = [0u32; 8];
        let mut share = [f32::NAN; 2];
        let samples = 100_000;
        let mut rng = Rng::new(5, Stream::Oracle, 0);
        for _ in 0..samples {
            let s = sampler
                .sample_area_at(&scene, &choice, [rng.next_f32(), rng.next_f32(), rng.next_f32()])
                .unwrap();
            let t = if s.position.x < 1.5 { 0 } else { 1 };
            // Barycentric coordinates on the triangle as indexed: (a, c, b) for the winding above.
            let [a, b, c] = scene.triangle(t);
            let (e1, e2, q) = (b - a, c - a, s.position - a);
            let d = e1.cross(e2);
            let w1 = q.cross(e2).dot(d) / d.length_squared();
            let w2 = e1.cross(q).dot(d) / d.length_squared();
            // Midpoint subdivision: corner triangles where a weight exceeds 1/2, else the middle.
            let sub = if w1 > 0.5 {
                1
            } else if w2 > 0.5 {
                2
            } else if 1.0 - w1 - w2 > 0.5 {
                0
            } else {
                3
            };
            counts[t * 4 + sub] += 1;
            let p = s.pdf_area * 0.5 * d.length();
            assert!(
                share[t].is_nan() || (share[t] - p).abs() < 1e-6,
                "emitter {t}: probability {p}, before {}",
                share[t]
            );
            share[t] = p;
        }
        assert!((share[0] + share[1] - 1.0).abs() < 1e-5, "probabilities {share:?}");
        let powers = [0.5 * 1.0, 3.0 * 4.0]; // area x radiance
        assert!(
            share[0] > powers[0] / (powers[0] + powers[1]),
            "the nearer emitter gains over its power share: {share:?}"
        );
        let mut chi2 = 0.0f64;
        for t in 0..2 {
            let expected = samples as f64 * share[t] as f64 / 4.0;
            for sub in 0..4 {
                chi2 += (counts[t * 4 + sub] as f64 - expected).powi(2) / expected;
            }
        }
        // 7 degrees of freedom: the 0.999 quantile is 24.3.
        println!(
            "area-light sampling: chi2 = {chi2:.2} (7 dof, reject above 24.3), counts {counts:?}"
        );
        assert!(chi2 < 24.3, "chi2 = {chi2}, counts {counts:?}");
    }
}
