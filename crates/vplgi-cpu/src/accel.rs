//! The scene as the CPU stages see it: Embree's acceleration structure, the light sampler and the
//! few scale-dependent constants (ray offsets, geometry-term clamp).

use crate::lights::LightSampler;
use glam::{Vec2, Vec3};
use vplgi_embree::{Device, EmbreeError};
use vplgi_scene::Scene;
use vplgi_shared::bsdf::{Bsdf, Surface, Transport};

/// A scene prepared for the CPU stages.
pub struct CpuScene<'a> {
    pub scene: &'a Scene,
    pub rt: vplgi_embree::Scene,
    pub lights: LightSampler,
    /// Bounding-box diagonal: the length unit of every relative parameter.
    pub extent: f32,
    /// How far ray end points are pushed off their surfaces ([`Scene::ray_epsilon`]).
    pub eps: f32,
}

pub use vplgi_types::params::{SEGMENT_TFAR, SEGMENT_TNEAR};

/// A shadow ray as the tracer is asked it: `origin + t dir` blocked or not for t in
/// (`tmin`, `tmax`), the origin already pushed off its surface. Direct lighting hands its rays
/// out in this form so that `vplgi verify` can judge the very same ray in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSpan {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

/// What a ray sees where it hits a surface.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub position: Vec3,
    /// Geometric normal turned to face the ray's origin.
    pub ng: Vec3,
    /// Shading normal in the same hemisphere as `ng`.
    pub ns: Vec3,
    pub albedo: Vec3,
    /// Radiance emitted back along the ray (zero unless the ray hit an emitter's front side).
    pub emitted: Vec3,
    pub triangle: u32,
    pub t: f32,
    /// What the surface scatters like; its colour is `albedo`.
    pub surface: Surface,
    /// The index of its material.
    pub material: u32,
    /// Whether the ray hit the triangle's front side (where its geometric normal points).
    pub facing: bool,
}

impl SurfaceHit {
    /// The BSDF here.
    pub fn bsdf(&self) -> Bsdf {
        self.surface.with_colour(self.albedo)
    }

    /// Where a ray that arrived along `dir` leaves this mirror or glass, and with what weight:
    /// the BSDF's sample with `u1` choosing reflection or refraction by Fresnel. None where the
    /// surface sends nothing.
    pub fn scatter_specular(
        &self,
        dir: Vec3,
        u1: f32,
        transport: Transport,
    ) -> Option<(Vec3, Vec3)> {
        self.scatter(dir, u1, Vec2::ZERO, transport)
    }

    /// Where a ray that arrived along `dir` leaves, and with what weight (eval / pdf, the colour
    /// included): the BSDF's sample from `u1` (which lobe) and `u` (where in it). None where the
    /// surface sends nothing. The local frame's +z is the side the normal points to, glass's
    /// outside, whose Fresnel term tells entering from leaving by the sign of cos θ_i.
    pub fn scatter(
        &self,
        dir: Vec3,
        u1: f32,
        u: Vec2,
        transport: Transport,
    ) -> Option<(Vec3, Vec3)> {
        let n = if self.facing { self.ns } else { -self.ns };
        let s = self.bsdf().sample_about(n, -dir, u1, u, transport)?;
        Some((s.wo, s.weight))
    }
}

impl<'a> CpuScene<'a> {
    pub fn new(scene: &'a Scene, device: &Device) -> Result<CpuScene<'a>, EmbreeError> {
        let rt = vplgi_embree::Scene::new(device, &scene.positions, &scene.indices)?;
        let extent = scene.extent().max(1e-6);
        Ok(CpuScene {
            scene,
            rt,
            lights: LightSampler::new(scene),
            extent,
            eps: scene.ray_epsilon(),
        })
    }

    /// Closest surface along `origin + t dir`, t in (0, inf).
    pub fn trace(&self, origin: Vec3, dir: Vec3) -> Option<SurfaceHit> {
        self.trace_beyond(origin, dir, 0.0)
    }

    /// Closest surface along `origin + t dir`, t in (`tnear`, inf).
    pub fn trace_beyond(&self, origin: Vec3, dir: Vec3, tnear: f32) -> Option<SurfaceHit> {
        let hit = self.rt.intersect(origin, dir, tnear, f32::INFINITY)?;
        let t = hit.triangle as usize;
        let [a, b, c] = self.scene.triangle(t);
        // Interpolating the corners is more accurate than origin + t * dir far from the origin.
        let position = a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v;
        let front = self.scene.geometric_normal(t);
        let facing = front.dot(dir) < 0.0;
        let ng = if facing { front } else { -front };
        let mut ns = self.scene.shading_normal(t, hit.u, hit.v);
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let emitted = if facing { self.scene.emission(t) } else { Vec3::ZERO };
        Some(SurfaceHit {
            position,
            ng,
            ns,
            albedo: self.scene.albedo(t, hit.u, hit.v),
            emitted,
            triangle: hit.triangle,
            t: hit.t,
            surface: self.scene.surface(t),
            material: self.scene.material_ids[t],
            facing,
        })
    }

    /// Pushes `p` off its surface (normal `n`) towards the side where `toward` lies.
    #[inline]
    pub fn offset_toward(&self, p: Vec3, n: Vec3, toward: Vec3) -> Vec3 {
        let side = if n.dot(toward - p) >= 0.0 { 1.0 } else { -1.0 };
        p + n * (side * self.eps)
    }

    /// The shadow segment between two surface points, as (origin, direction) for t in
    /// (`SEGMENT_TNEAR`, `SEGMENT_TFAR`): both ends pushed off their surfaces, so neither end's
    /// own surface counts as a blocker (SPEC, "shadow-ray endpoints").
    #[inline]
    pub fn shadow_segment(&self, p: Vec3, np: Vec3, q: Vec3, nq: Vec3) -> (Vec3, Vec3) {
        let a = self.offset_toward(p, np, q);
        let b = self.offset_toward(q, nq, p);
        (a, b - a)
    }

    /// The span [`Self::visible`] tests.
    #[inline]
    pub fn segment_span(&self, p: Vec3, np: Vec3, q: Vec3, nq: Vec3) -> ShadowSpan {
        let (origin, dir) = self.shadow_segment(p, np, q, nq);
        ShadowSpan { origin, dir, tmin: SEGMENT_TNEAR, tmax: SEGMENT_TFAR }
    }

    /// The span [`Self::visible_toward`] tests: from the pushed-off point to infinity.
    #[inline]
    pub fn toward_span(&self, p: Vec3, np: Vec3, dir: Vec3) -> ShadowSpan {
        ShadowSpan {
            origin: self.offset_toward(p, np, p + dir),
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// The span [`Self::visible_from_surface`] tests, stopping eps short of the light; `None`
    /// when the light is within eps of the pushed-off point (not visible).
    #[inline]
    pub fn from_surface_span(&self, p: Vec3, np: Vec3, light: Vec3) -> Option<ShadowSpan> {
        let origin = self.offset_toward(p, np, light);
        let dir = light - origin;
        let len = dir.length();
        (len > self.eps).then(|| ShadowSpan {
            origin,
            dir,
            tmin: SEGMENT_TNEAR,
            tmax: 1.0 - self.eps / len,
        })
    }

    /// Whether nothing blocks `span`.
    #[inline]
    pub fn unoccluded(&self, span: ShadowSpan) -> bool {
        !self.rt.occluded(span.origin, span.dir, span.tmin, span.tmax)
    }

    /// Visibility between two surface points: nothing blocks their [`Self::shadow_segment`].
    #[inline]
    pub fn visible(&self, p: Vec3, np: Vec3, q: Vec3, nq: Vec3) -> bool {
        self.unoccluded(self.segment_span(p, np, q, nq))
    }

    /// Visibility from a surface point along unit direction `dir` to infinity (a directional
    /// light).
    #[inline]
    pub fn visible_toward(&self, p: Vec3, np: Vec3, dir: Vec3) -> bool {
        self.unoccluded(self.toward_span(p, np, dir))
    }

    /// Visibility between a surface point and a point in free space (a punctual light). The
    /// segment stops eps short of the light, so a light mounted on a surface is not blocked by it.
    #[inline]
    pub fn visible_from_surface(&self, p: Vec3, np: Vec3, light: Vec3) -> bool {
        self.from_surface_span(p, np, light).is_some_and(|span| self.unoccluded(span))
    }
}
