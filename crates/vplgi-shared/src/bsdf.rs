//! Surface scattering as Mitsuba 3 defines it, so that an independent renderer checks vplgi's
//! images exactly. Every function works in the local shading frame: the normal is +z, `wi`
//! points toward where the light goes next on a camera path (toward the viewer), `wo` the
//! sampled or queried direction, both unit length.
//!
//! | [`Bsdf`] | Mitsuba 3 | glTF 2.0 |
//! |---|---|---|
//! | `Diffuse` | `twosided(diffuse)` | metallic 0 |
//! | `Mirror` | `twosided(conductor material="none")` | metallic 1, roughness 0 |
//! | `RoughConductor` | `twosided(roughconductor distribution="ggx" material="none")` | metallic 1, roughness r: α = r² |
//! | `Dielectric` | `dielectric` | transmission 1 with a volume |
//! | `ThinDielectric` | `thindielectric` | transmission 1, thin-walled |
//! | `Blend` | `twosided(blendbsdf(weight = metallic, diffuse, roughconductor))` | metallic in (0, 1) |
//!
//! As in Mitsuba, [`Bsdf::eval`] is the BSDF times the cosine of `wo` (what a light's
//! contribution is multiplied by), [`Bsdf::pdf`] the solid-angle density [`Bsdf::sample`] draws
//! `wo` with (0 for a delta lobe, which `eval` never sees), and a sample's `weight` is eval / pdf
//! of the lobe it came from. The conductors use `material="none"`: a reflectance and no Fresnel
//! term, which is what glTF's metal colour means at normal incidence.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use vplgi_types::pod::{
    BSDF_BLEND, BSDF_DIELECTRIC, BSDF_DIFFUSE, BSDF_MIRROR, BSDF_ROUGH_CONDUCTOR,
    BSDF_THIN_DIELECTRIC,
};
use vplgi_types::BsdfRecord;

/// One surface's scattering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection.
    Diffuse { reflectance: Vec3 },
    /// A perfect mirror.
    Mirror { reflectance: Vec3 },
    /// GGX microfacets (Walter et al. 2007) with the separable Smith shadowing and visible-normal
    /// sampling, Mitsuba's defaults; `alpha` is glTF's roughness squared, in (0, 1].
    RoughConductor { reflectance: Vec3, alpha: f32 },
    /// A smooth interface into a medium of relative index `eta` (interior over exterior): solid
    /// glass, which needs a closed mesh whose normals point out.
    Dielectric { eta: f32 },
    /// A thin smooth slab of index `eta`: light passes straight through or reflects, with the
    /// slab's internal reflections summed.
    ThinDielectric { eta: f32 },
    /// `1 - metallic` of `Diffuse { base }` and `metallic` of `RoughConductor { base, alpha }`.
    Blend { metallic: f32, base: Vec3, alpha: f32 },
}

/// What a material is made of, apart from its colour: its glTF base colour (times its texture,
/// at a hit) is the reflectance of the [`Bsdf`] it becomes there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Surface {
    #[default]
    Diffuse,
    Mirror,
    RoughConductor {
        alpha: f32,
    },
    Dielectric {
        eta: f32,
    },
    ThinDielectric {
        eta: f32,
    },
    Blend {
        metallic: f32,
        alpha: f32,
    },
}

impl Surface {
    /// The BSDF of this surface where its colour is `base`.
    pub fn with_colour(self, base: Vec3) -> Bsdf {
        match self {
            Surface::Diffuse => Bsdf::Diffuse { reflectance: base },
            Surface::Mirror => Bsdf::Mirror { reflectance: base },
            Surface::RoughConductor { alpha } => Bsdf::RoughConductor { reflectance: base, alpha },
            Surface::Dielectric { eta } => Bsdf::Dielectric { eta },
            Surface::ThinDielectric { eta } => Bsdf::ThinDielectric { eta },
            Surface::Blend { metallic, alpha } => Bsdf::Blend { metallic, base, alpha },
        }
    }

    /// Whether it reflects light into a lobe that depends on where the light came from (rough
    /// metal, alone or blended): a VPL or shading point on it needs [`Surface::lobe`].
    pub fn is_glossy(&self) -> bool {
        matches!(self, Surface::RoughConductor { .. } | Surface::Blend { .. })
    }

    /// Whether every lobe is a delta (a mirror, glass), whatever the colour: [`Bsdf::is_specular`].
    pub fn is_specular(&self) -> bool {
        self.with_colour(Vec3::ONE).is_specular()
    }

    /// The BSDF of a white surface of this kind from `wi` to `wo` (unit world directions about
    /// the shading normal `n`, either may be the one light arrives from: the BSDFs are
    /// reciprocal), over a white Lambertian surface's 1 / π. A diffuse surface's light times
    /// this is a glossy one's: a receiver's, seen from `wi`, lit from `wo`; a VPL's, lit from
    /// `wi`, seen from `wo`. Exactly 1 for a diffuse surface, so diffuse images keep their
    /// arithmetic; 0 for `wo` on the other side of the surface from `wi`, and for the delta
    /// lobes, which no VPL or shading point stands on.
    pub fn lobe(self, n: Vec3, wi: Vec3, wo: Vec3) -> f32 {
        if self == Surface::Diffuse {
            return 1.0;
        }
        let (t, b) = vplgi_types::sampling::orthonormal_basis(n);
        let local = |v: Vec3| Vec3::new(v.dot(t), v.dot(b), v.dot(n));
        let (wi, wo) = (local(wi), local(wo));
        if wo.z == 0.0 {
            return 0.0;
        }
        PI * self.with_colour(Vec3::ONE).eval(wi, wo).x / wo.z.abs()
    }

    /// Whether light passes through it (solid or thin glass).
    pub fn is_glass(&self) -> bool {
        matches!(self, Surface::Dielectric { .. } | Surface::ThinDielectric { .. })
    }

    /// What it is, in words: "a mirror", "glass (index 1.5)".
    pub fn describe(&self) -> String {
        match *self {
            Surface::Diffuse => "diffuse".into(),
            Surface::Mirror => "a mirror".into(),
            Surface::RoughConductor { alpha } => format!("a rough metal (GGX alpha {alpha})"),
            Surface::Dielectric { eta } => format!("glass (index {eta})"),
            Surface::ThinDielectric { eta } => format!("a thin pane (index {eta})"),
            Surface::Blend { metallic, alpha } => {
                format!("{metallic} metal (GGX alpha {alpha}) on diffuse")
            }
        }
    }
}

/// Whether a sampled weight carries radiance (camera paths: a refracted ray's radiance scales by
/// the squared ratio of indices) or importance and power (light paths, photons: it does not).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    Radiance,
    Importance,
}

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub wo: Vec3,
    /// eval / pdf of the lobe `wo` was drawn from (Mitsuba's convention).
    pub weight: Vec3,
    /// The density `wo` was drawn with: solid angle for a smooth lobe, the lobe's probability for
    /// a delta one.
    pub pdf: f32,
    /// Whether `wo` came from a delta lobe (a mirror or refraction direction).
    pub delta: bool,
}

/// The unpolarised Fresnel reflectance of a smooth dielectric interface of relative index `eta`
/// for a ray arriving at `cos_i` (negative from inside), as Mitsuba's `fresnel`: (reflectance,
/// cosine of the refracted direction with the sign of the side it leaves on, η_it, η_ti).
/// Total internal reflection gives reflectance 1.
pub fn fresnel(cos_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_t2 = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    let (ci, ct) = (cos_i.abs(), cos_t2.max(0.0).sqrt());
    let r = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    (r, if outside { -ct } else { ct }, eta_it, eta_ti)
}

/// GGX's normal distribution D(m) for roughness `alpha`, in Mitsuba's form 1 / (π α² ((m_x² +
/// m_y²) / α² + m_z²)²): it never subtracts nearly equal numbers, where the textbook
/// (cos² θ (α² - 1) + 1) loses all its digits near the peak of a smooth lobe.
pub fn ggx_d(m: Vec3, alpha: f32) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    1.0 / (PI * a2 * t * t)
}

/// Smith's masking G1(v, m) for GGX: 0 where `v` sees the microfacet `m` from behind or the
/// macro-surface from the other side.
pub fn ggx_g1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    let xy2 = alpha * alpha * (v.x * v.x + v.y * v.y);
    if xy2 == 0.0 {
        return 1.0;
    }
    2.0 / (1.0 + (1.0 + xy2 / (v.z * v.z)).sqrt())
}

/// A microfacet normal drawn from the normals `wi` sees (Heitz 2018), density
/// D(m) G1(wi, m) max(0, wi · m) / wi.z.
pub fn ggx_sample_visible(wi: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let vh = Vec3::new(alpha * wi.x, alpha * wi.y, wi.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { Vec3::X };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    // φ in [-π, π): WGSL bounds the error of sin and cos only there.
    let phi = PI * (2.0 * u.y - 1.0);
    let (p1, p2) = (r * phi.cos(), r * phi.sin());
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

fn reflect(wi: Vec3) -> Vec3 {
    Vec3::new(-wi.x, -wi.y, wi.z)
}

/// The twosided wrapper: a one-sided lobe seen from below (`wi.z < 0`) is evaluated mirrored
/// through the surface's plane, `wi` and `wo` alike.
fn mirrored(v: Vec3, below: bool) -> Vec3 {
    if below {
        Vec3::new(v.x, v.y, -v.z)
    } else {
        v
    }
}

fn diffuse_eval(reflectance: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return Vec3::ZERO;
    }
    reflectance * wo.z / PI
}

fn diffuse_pdf(wi: Vec3, wo: Vec3) -> f32 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    wo.z / PI
}

fn diffuse_sample(reflectance: Vec3, wi: Vec3, u: Vec2) -> Option<Sample> {
    if wi.z <= 0.0 {
        return None;
    }
    let wo = vplgi_types::sampling::cosine_hemisphere(Vec3::Z, u.x, u.y);
    (wo.z > 0.0).then_some(Sample { wo, weight: reflectance, pdf: wo.z / PI, delta: false })
}

fn rough_eval(reflectance: Vec3, alpha: f32, wi: Vec3, wo: Vec3) -> Vec3 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return Vec3::ZERO;
    }
    let m = (wi + wo).normalize();
    let g = ggx_g1(wi, m, alpha) * ggx_g1(wo, m, alpha);
    reflectance * (ggx_d(m, alpha) * g / (4.0 * wi.z))
}

fn rough_pdf(alpha: f32, wi: Vec3, wo: Vec3) -> f32 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let m = (wi + wo).normalize();
    if wi.dot(m) <= 0.0 || wo.dot(m) <= 0.0 {
        return 0.0;
    }
    ggx_d(m, alpha) * ggx_g1(wi, m, alpha) / (4.0 * wi.z)
}

fn rough_sample(reflectance: Vec3, alpha: f32, wi: Vec3, u: Vec2) -> Option<Sample> {
    if wi.z <= 0.0 {
        return None;
    }
    let m = ggx_sample_visible(wi, alpha, u);
    let wo = 2.0 * wi.dot(m) * m - wi;
    if wo.z <= 0.0 {
        return None;
    }
    let pdf = rough_pdf(alpha, wi, wo);
    (pdf > 0.0).then(|| Sample {
        wo,
        weight: reflectance * ggx_g1(wo, m, alpha),
        pdf,
        delta: false,
    })
}

impl Bsdf {
    /// Every kind, in `colour`: the rough ones at three roughnesses, glass entering a denser
    /// medium and leaving one, a blend of 0.4 metal. What the tests and `vplgi verify` cover.
    pub fn every_kind(colour: Vec3) -> Vec<Bsdf> {
        let mut m = vec![
            Bsdf::Diffuse { reflectance: colour },
            Bsdf::Mirror { reflectance: colour },
            Bsdf::Dielectric { eta: 1.5 },
            Bsdf::Dielectric { eta: 1.0 / 1.33 },
            Bsdf::ThinDielectric { eta: 1.5 },
        ];
        for alpha in [0.1f32, 0.3, 0.6] {
            m.push(Bsdf::RoughConductor { reflectance: colour, alpha });
            m.push(Bsdf::Blend { metallic: 0.4, base: colour, alpha });
        }
        m
    }

    /// The record the GPU twin (`shaders/common/bsdf.wgsl`) reads.
    pub fn record(&self) -> BsdfRecord {
        let r = |kind, reflectance: Vec3| BsdfRecord {
            kind,
            reflectance: reflectance.to_array(),
            ..Default::default()
        };
        match *self {
            Bsdf::Diffuse { reflectance } => r(BSDF_DIFFUSE, reflectance),
            Bsdf::Mirror { reflectance } => r(BSDF_MIRROR, reflectance),
            Bsdf::RoughConductor { reflectance, alpha } => {
                BsdfRecord { alpha, ..r(BSDF_ROUGH_CONDUCTOR, reflectance) }
            }
            Bsdf::Dielectric { eta } => BsdfRecord { eta, ..r(BSDF_DIELECTRIC, Vec3::ZERO) },
            Bsdf::ThinDielectric { eta } => {
                BsdfRecord { eta, ..r(BSDF_THIN_DIELECTRIC, Vec3::ZERO) }
            }
            Bsdf::Blend { metallic, base, alpha } => {
                BsdfRecord { alpha, metallic, ..r(BSDF_BLEND, base) }
            }
        }
    }

    /// Whether every lobe is a delta: the surface is seen only along mirror and refraction
    /// directions, never lit by a VPL or a shadow ray.
    pub fn is_specular(&self) -> bool {
        matches!(self, Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. })
    }

    /// The BSDF times |cos θ_o|; 0 for the delta lobes.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        let below = wi.z < 0.0;
        let (wi, wo) = (mirrored(wi, below), mirrored(wo, below));
        match *self {
            Bsdf::Diffuse { reflectance } => diffuse_eval(reflectance, wi, wo),
            Bsdf::RoughConductor { reflectance, alpha } => rough_eval(reflectance, alpha, wi, wo),
            Bsdf::Blend { metallic, base, alpha } => {
                (1.0 - metallic) * diffuse_eval(base, wi, wo)
                    + metallic * rough_eval(base, alpha, wi, wo)
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. } => {
                Vec3::ZERO
            }
        }
    }

    /// The solid-angle density of [`Self::sample`] drawing `wo`; 0 for the delta lobes.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let below = wi.z < 0.0;
        let (wi, wo) = (mirrored(wi, below), mirrored(wo, below));
        match *self {
            Bsdf::Diffuse { .. } => diffuse_pdf(wi, wo),
            Bsdf::RoughConductor { alpha, .. } => rough_pdf(alpha, wi, wo),
            Bsdf::Blend { metallic, alpha, .. } => {
                (1.0 - metallic) * diffuse_pdf(wi, wo) + metallic * rough_pdf(alpha, wi, wo)
            }
            Bsdf::Mirror { .. } | Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. } => 0.0,
        }
    }

    /// [`Self::sample`] in world space: `wi` and the sampled `wo` are world directions, the
    /// local frame's +z the unit normal `n`.
    pub fn sample_about(
        &self,
        n: Vec3,
        wi: Vec3,
        u1: f32,
        u: Vec2,
        transport: Transport,
    ) -> Option<Sample> {
        let (t, b) = vplgi_types::sampling::orthonormal_basis(n);
        let local = Vec3::new(wi.dot(t), wi.dot(b), wi.dot(n));
        let s = self.sample(local, u1, u, transport)?;
        Some(Sample { wo: t * s.wo.x + b * s.wo.y + n * s.wo.z, ..s })
    }

    /// A direction `wo` for `wi` from uniform numbers `u1` (which lobe) and `u` (where in it).
    /// None where the surface sends nothing (`wi` in its plane, or a microfacet reflection below
    /// the surface).
    pub fn sample(&self, wi: Vec3, u1: f32, u: Vec2, transport: Transport) -> Option<Sample> {
        let below = wi.z < 0.0;
        let flip = |s: Sample| Sample { wo: mirrored(s.wo, below), ..s };
        let up = mirrored(wi, below);
        match *self {
            Bsdf::Diffuse { reflectance } => diffuse_sample(reflectance, up, u).map(flip),
            Bsdf::RoughConductor { reflectance, alpha } => {
                rough_sample(reflectance, alpha, up, u).map(flip)
            }
            Bsdf::Blend { metallic, base, alpha } => {
                if u1 <= metallic {
                    rough_sample(base, alpha, up, u).map(flip)
                } else {
                    diffuse_sample(base, up, u).map(flip)
                }
            }
            Bsdf::Mirror { reflectance } => (wi.z != 0.0).then_some(Sample {
                wo: reflect(wi),
                weight: reflectance,
                pdf: 1.0,
                delta: true,
            }),
            Bsdf::Dielectric { eta } => {
                let (r, cos_t, _, eta_ti) = fresnel(wi.z, eta);
                if u1 <= r {
                    Some(Sample { wo: reflect(wi), weight: Vec3::ONE, pdf: r, delta: true })
                } else {
                    let wo = Vec3::new(-eta_ti * wi.x, -eta_ti * wi.y, cos_t);
                    let scale =
                        if transport == Transport::Radiance { eta_ti * eta_ti } else { 1.0 };
                    Some(Sample { wo, weight: Vec3::splat(scale), pdf: 1.0 - r, delta: true })
                }
            }
            Bsdf::ThinDielectric { eta } => {
                let (r, t) = thin_reflectance(wi.z, eta);
                if u1 <= r {
                    Some(Sample { wo: reflect(wi), weight: Vec3::ONE, pdf: r, delta: true })
                } else {
                    Some(Sample { wo: -wi, weight: Vec3::ONE, pdf: t, delta: true })
                }
            }
        }
    }
}

/// A thin slab's reflectance and transmittance at `cos_i`, its internal reflections summed:
/// r + t² r / (1 - r²) and what is left, as Mitsuba's `thindielectric`.
pub fn thin_reflectance(cos_i: f32, eta: f32) -> (f32, f32) {
    let r = fresnel(cos_i.abs(), eta).0;
    let t = 1.0 - r;
    let r = if r < 1.0 { r + t * t * r / (1.0 - r * r) } else { r };
    (r, 1.0 - r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vplgi_types::{Rng, Stream};

    fn rng(seed: u32) -> Rng {
        Rng::new(seed, Stream::Scramble, 0)
    }

    fn direction(r: &mut Rng) -> Vec3 {
        vplgi_types::sampling::uniform_sphere(r.next_f32(), r.next_f32())
    }

    fn models() -> Vec<Bsdf> {
        Bsdf::every_kind(Vec3::ONE)
    }

    /// Fresnel's equations for unpolarised light, from Snell's law in f64: an evaluation
    /// independent of [`fresnel`]'s form (Mitsuba's), so Schlick's approximation or a swapped
    /// η fails it.
    fn fresnel_f64(cos_i: f64, eta: f64) -> f64 {
        let (n1, n2) = if cos_i >= 0.0 { (1.0, eta) } else { (eta, 1.0) };
        let ci = cos_i.abs();
        let sin_t = n1 / n2 * (1.0 - ci * ci).max(0.0).sqrt();
        if sin_t >= 1.0 {
            return 1.0;
        }
        let ct = (1.0 - sin_t * sin_t).sqrt();
        let rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
        let rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
        0.5 * (rs * rs + rp * rp)
    }

    #[test]
    fn fresnel_is_the_exact_dielectric_reflectance() {
        let mut r = rng(1);
        for _ in 0..20_000 {
            let cos_i = 2.0 * r.next_f32() - 1.0;
            let eta = 1.05 + 1.5 * r.next_f32();
            let (got, cos_t, eta_it, eta_ti) = fresnel(cos_i, eta);
            let want = fresnel_f64(cos_i as f64, eta as f64);
            assert!(
                (got as f64 - want).abs() < 2e-5,
                "cos_i {cos_i}, eta {eta}: {got} against {want}"
            );
            assert!((eta_it * eta_ti - 1.0).abs() < 1e-6);
            // Snell: η_i sin θ_i = η_t sin θ_t, and the refracted ray leaves on the other side.
            if got < 1.0 {
                let (sin_i, sin_t) =
                    ((1.0 - cos_i * cos_i).sqrt(), (1.0 - cos_t * cos_t).max(0.0).sqrt());
                assert!((sin_i - eta_it * sin_t).abs() < 1e-4, "cos_i {cos_i}, eta {eta}");
                assert!(cos_t * cos_i <= 0.0);
            }
        }
        assert_eq!(fresnel(0.5, 1.0).0, 0.0);
        assert_eq!(fresnel(-0.1, 1.5).0, 1.0, "total internal reflection");
    }

    /// D(m) by its tan θ form (Walter et al. Eq. 33), in f64.
    fn ggx_d_f64(m: Vec3, alpha: f64) -> f64 {
        let c = m.z as f64;
        if c <= 0.0 {
            return 0.0;
        }
        let tan2 = (1.0 - c * c) / (c * c);
        let a2 = alpha * alpha;
        1.0 / (std::f64::consts::PI * a2 * c.powi(4) * (1.0 + tan2 / a2).powi(2))
    }

    /// G1 by Walter et al. Eq. 34, in f64.
    fn ggx_g1_f64(v: Vec3, m: Vec3, alpha: f64) -> f64 {
        if (v.dot(m) as f64) * (v.z as f64) <= 0.0 {
            return 0.0;
        }
        let c = v.z as f64;
        let tan2 = (1.0 - c * c).max(0.0) / (c * c);
        2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
    }

    /// The rough conductor against Mitsuba's formula evaluated independently: white, no Fresnel
    /// (`material="none"`), D G1(wi) G1(wo) / (4 cos θ_i), on random directions of both sides.
    #[test]
    fn rough_conductor_is_mitsubas_formula() {
        let mut r = rng(2);
        for _ in 0..20_000 {
            let alpha = 0.05 + 0.95 * r.next_f32();
            let (wi, wo) = (direction(&mut r), direction(&mut r));
            let got = Bsdf::RoughConductor { reflectance: Vec3::ONE, alpha }.eval(wi, wo).x as f64;
            let (wi, wo) = if wi.z < 0.0 {
                (wi * Vec3::new(1.0, 1.0, -1.0), wo * Vec3::new(1.0, 1.0, -1.0))
            } else {
                (wi, wo)
            };
            let want = if wi.z > 0.0 && wo.z > 0.0 {
                let m = (wi + wo).normalize();
                let a = alpha as f64;
                ggx_d_f64(m, a) * ggx_g1_f64(wi, m, a) * ggx_g1_f64(wo, m, a) / (4.0 * wi.z as f64)
            } else {
                0.0
            };
            assert!(
                (got - want).abs() <= 1e-4 * want.max(1.0),
                "alpha {alpha}, wi {wi}, wo {wo}: {got} against {want}"
            );
        }
    }

    /// ∫ D(m) cos θ_m dω = 1: the distribution is normalised (midpoint rule in cos θ, exact in φ).
    #[test]
    fn ggx_distribution_projects_to_one() {
        for alpha in [0.1f32, 0.3, 0.6, 1.0] {
            let n = 200_000;
            let sum: f64 = (0..n)
                .map(|i| {
                    let c = (i as f64 + 0.5) / n as f64;
                    let m = Vec3::new((1.0 - c * c).sqrt() as f32, 0.0, c as f32);
                    ggx_d(m, alpha) as f64 * c * 2.0 * std::f64::consts::PI / n as f64
                })
                .sum();
            assert!((sum - 1.0).abs() < 2e-3, "alpha {alpha}: {sum}");
        }
    }

    /// f(wi, wo) = f(wo, wi) for every smooth lobe: eval carries |cos θ_o|, so eval(wi, wo) /
    /// cos θ_o = eval(wo, wi) / cos θ_i.
    #[test]
    fn smooth_lobes_are_reciprocal() {
        let mut r = rng(3);
        for bsdf in models().into_iter().filter(|b| !b.is_specular()) {
            for _ in 0..5_000 {
                let (wi, wo) = (direction(&mut r), direction(&mut r));
                let a = bsdf.eval(wi, wo) / wo.z.abs();
                let b = bsdf.eval(wo, wi) / wi.z.abs();
                assert!(
                    (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1.0),
                    "{bsdf:?}: {a} against {b}"
                );
            }
        }
    }

    /// White furnace: the mean sampled weight is the albedo. Mirrors and glass keep all the
    /// energy (to 1e-3; glass under importance transport, whose weights carry no η²); the diffuse
    /// surface too; microfacets lose what shadowing removes, never gain.
    #[test]
    fn white_furnace() {
        let mut r = rng(4);
        for bsdf in models() {
            for cos_i in [0.05f32, 0.3, 0.7, 1.0, -0.5] {
                let wi = Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i);
                let n = 40_000;
                let mut sum = 0.0f64;
                for _ in 0..n {
                    let (u1, u) = (r.next_f32(), Vec2::new(r.next_f32(), r.next_f32()));
                    if let Some(s) = bsdf.sample(wi, u1, u, Transport::Importance) {
                        sum += s.weight.x as f64;
                        if !s.delta {
                            assert!(s.pdf > 0.0 && (s.wo.length() - 1.0).abs() < 1e-4, "{bsdf:?}");
                        }
                    }
                }
                let albedo = sum / n as f64;
                let lossless = matches!(
                    bsdf,
                    Bsdf::Mirror { .. }
                        | Bsdf::Dielectric { .. }
                        | Bsdf::ThinDielectric { .. }
                        | Bsdf::Diffuse { .. }
                );
                if lossless {
                    assert!(
                        (albedo - 1.0).abs() < 1e-3,
                        "{bsdf:?} at cos {cos_i}: albedo {albedo}"
                    );
                } else {
                    assert!(
                        albedo <= 1.0 + 1e-3 && albedo > 0.5,
                        "{bsdf:?} at cos {cos_i}: albedo {albedo}"
                    );
                }
            }
        }
    }

    /// A smooth lobe's sample weight is eval / pdf at the sampled direction (for a blend, of the
    /// component sampled, as Mitsuba's `blendbsdf` returns it).
    #[test]
    fn sample_weights_are_eval_over_pdf() {
        let mut r = rng(5);
        for bsdf in models()
            .into_iter()
            .filter(|b| matches!(b, Bsdf::Diffuse { .. } | Bsdf::RoughConductor { .. }))
        {
            for _ in 0..5_000 {
                let wi = direction(&mut r);
                let Some(s) = bsdf.sample(
                    wi,
                    r.next_f32(),
                    Vec2::new(r.next_f32(), r.next_f32()),
                    Transport::Radiance,
                ) else {
                    continue;
                };
                let (e, p) = (bsdf.eval(wi, s.wo), bsdf.pdf(wi, s.wo));
                assert!((s.pdf - p).abs() <= 1e-3 * p, "{bsdf:?}: pdf {} against {p}", s.pdf);
                assert!(
                    (s.weight - e / p).abs().max_element()
                        <= 1e-3 * s.weight.max_element().max(1e-3),
                    "{bsdf:?}"
                );
            }
        }
    }

    /// Glass seen from a camera: a refracted ray's radiance scales by η_ti² (Mitsuba's radiance
    /// mode), and the refracted direction obeys Snell's law.
    #[test]
    fn refraction_scales_radiance_by_the_squared_index_ratio() {
        let glass = Bsdf::Dielectric { eta: 1.5 };
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let s = glass.sample(wi, 0.999, Vec2::ZERO, Transport::Radiance).expect("refraction");
        assert!(s.wo.z < 0.0 && (s.weight.x - 1.0 / 2.25).abs() < 1e-6, "{s:?}");
        assert!((0.6 - 1.5 * s.wo.x.abs()).abs() < 1e-5, "Snell: {s:?}");
        let out = glass.sample(s.wo, 0.999, Vec2::ZERO, Transport::Radiance).expect("back out");
        assert!((out.weight.x - 2.25).abs() < 1e-5 && (out.wo - wi).length() < 1e-5, "{out:?}");
        assert_eq!(
            glass.sample(wi, 0.999, Vec2::ZERO, Transport::Importance).map(|s| s.weight),
            Some(Vec3::ONE)
        );
    }

    /// The χ² distribution's upper quantile for `df` degrees of freedom where the standard
    /// normal's is `z`.
    fn chi2_critical(df: f64, z: f64) -> f64 {
        // Wilson and Hilferty: (χ²/df)^(1/3) is close to normal.
        let a = 2.0 / (9.0 * df);
        df * (1.0 - a + z * a.sqrt()).powi(3)
    }

    /// Pearson's χ² between `n` samples of `bsdf` at `wi` and the counts its `pdf` predicts over
    /// a (cos θ, φ) grid of the sphere; bins expecting fewer than 5 are pooled. Returns (χ², df).
    fn chi2(bsdf: &Bsdf, pdf: impl Fn(Vec3) -> f32, wi: Vec3, n: usize, seed: u32) -> (f64, f64) {
        let (nc, np, sub) = (20usize, 40usize, 12usize);
        let bin = |w: Vec3| {
            let c = ((w.z + 1.0) / 2.0 * nc as f32).clamp(0.0, nc as f32 - 1.0) as usize;
            let phi = w.y.atan2(w.x).rem_euclid(2.0 * PI);
            c * np + ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1)
        };
        let mut observed = vec![0f64; nc * np];
        let mut r = rng(seed);
        for _ in 0..n {
            if let Some(s) = bsdf.sample(
                wi,
                r.next_f32(),
                Vec2::new(r.next_f32(), r.next_f32()),
                Transport::Radiance,
            ) {
                observed[bin(s.wo)] += 1.0;
            }
        }
        let mut expected = vec![0f64; nc * np];
        let (dc, dp) = (2.0 / nc as f64, 2.0 * std::f64::consts::PI / np as f64);
        for c in 0..nc {
            for p in 0..np {
                let mut sum = 0.0;
                for i in 0..sub {
                    for j in 0..sub {
                        let cz = -1.0 + dc * (c as f64 + (i as f64 + 0.5) / sub as f64);
                        let phi = dp * (p as f64 + (j as f64 + 0.5) / sub as f64);
                        let s = (1.0 - cz * cz).max(0.0).sqrt();
                        sum += pdf(Vec3::new(
                            (s * phi.cos()) as f32,
                            (s * phi.sin()) as f32,
                            cz as f32,
                        )) as f64;
                    }
                }
                expected[c * np + p] = sum * dc * dp / (sub * sub) as f64 * n as f64;
            }
        }
        let (mut stat, mut df, mut pooled_o, mut pooled_e) = (0.0, 0.0, 0.0, 0.0);
        for (o, e) in observed.iter().zip(&expected) {
            if *e < 5.0 {
                (pooled_o, pooled_e) = (pooled_o + o, pooled_e + e);
            } else {
                stat += (o - e) * (o - e) / e;
                df += 1.0;
            }
        }
        if pooled_e > 0.0 {
            stat += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
            df += 1.0;
        }
        (stat, df - 1.0)
    }

    /// Sampling draws directions with the density `pdf` states: a χ² test on a grid of the
    /// sphere at three roughnesses and three angles of incidence, at significance 1e-4 each (as
    /// Mitsuba's own BSDF tests do it). The test has power: a rough lobe's samples against a
    /// diffuse lobe's density are rejected.
    #[test]
    fn sampling_follows_the_pdf() {
        let z = 3.72; // the standard normal's upper 1e-4 quantile
        let mut seed = 10;
        for bsdf in models().into_iter().filter(|b| !b.is_specular()) {
            for cos_i in [0.2f32, 0.6, 0.95] {
                let wi = Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i);
                seed += 1;
                let (stat, df) = chi2(&bsdf, |wo| bsdf.pdf(wi, wo), wi, 200_000, seed);
                assert!(
                    stat < chi2_critical(df, z),
                    "{bsdf:?} at cos {cos_i}: χ² {stat:.1} on {df} degrees of freedom"
                );
                if let Bsdf::RoughConductor { .. } = bsdf {
                    let (bad, df) = chi2(&bsdf, |wo| diffuse_pdf(wi, wo), wi, 200_000, seed);
                    assert!(
                        bad > chi2_critical(df, z),
                        "{bsdf:?} at cos {cos_i}: a wrong density passed (χ² {bad:.1})"
                    );
                }
            }
        }
    }
}
