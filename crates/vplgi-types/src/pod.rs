//! Plain-old-data records that flow between stages.
//!
//! Layouts are chosen to match WGSL storage-buffer layout rules: every `vec3<f32>` is followed by
//! a 4-byte scalar so that a WGSL `struct { a: vec3<f32>, b: u32, ... }` has the same offsets and
//! size as the Rust struct.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Marker for "no triangle": a primary ray that left the scene.
pub const MISS: u32 = u32::MAX;

/// A virtual point light: light that arrived at a non-specular surface and is re-emitted from it
/// through the surface's BSDF.
///
/// `flux` is the power the VPL re-emits (incident particle power times the colour at the hit), so
/// on a diffuse surface its radiant intensity is `flux * cos(theta) / pi` around `normal`; on a
/// glossy one it is `flux` times the BSDF of a white surface of its kind, lit from `incoming`, times
/// cos θ (`vplgi_shared::bsdf::Surface::lobe`).
///
/// A caustic photon (`Deposit::CausticPhotons`) is the same record with `flux` the power that
/// arrived, before the surface's colour: `caustics` applies the receiver's BSDF itself.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Vpl {
    pub position: [f32; 3],
    /// Index of the light particle that deposited this VPL.
    pub path: u32,
    pub normal: [f32; 3],
    /// 1 for a VPL at the first surface a particle hit, 2 for the next one, ...
    pub bounce: u32,
    pub flux: [f32; 3],
    /// Mirrors and glass the particle passed on its way here, since it left the light.
    pub specular: u32,
    /// Unit direction back toward where the light came from (the particle's last vertex or the
    /// light), which a glossy VPL's lobe depends on.
    pub incoming: [f32; 3],
    /// The index of the material it lies on, whose BSDF it emits through.
    pub material: u32,
}

/// The surface seen through one camera sample.
///
/// `normal` is the shading normal, turned to face the camera. When `triangle == MISS` the sample
/// saw the background and every other field but `emitted` is zero.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShadingPoint {
    pub position: [f32; 3],
    /// Linear pixel index `y * width + x` this sample belongs to.
    pub pixel: u32,
    pub normal: [f32; 3],
    /// Index of the triangle that was hit, or [`MISS`].
    pub triangle: u32,
    /// Diffuse albedo (base colour, texture applied), linear RGB, times the throughput of the
    /// specular chain the camera ray followed to reach it.
    pub albedo: [f32; 3],
    /// Mirrors and glass the camera ray passed before reaching this point (at most
    /// `--specular-depth`).
    pub specular: u32,
    /// Radiance emitted towards the camera (non-zero on area lights, and on what mirrors and
    /// glass show of them): what the sample's own ray sees for a pixel-centre sample, the
    /// pixel's mean estimated from stratified rays
    /// ([`EMISSION_STRATA`](crate::params::EMISSION_STRATA)) for a jittered one, miss or hit.
    pub emitted: [f32; 3],
    /// The index of the hit's material, whose BSDF it reflects through (0 for a miss).
    pub material: u32,
    /// Unit direction from the point back along the ray that found it (toward the camera, or
    /// toward the last mirror or glass of its chain, or toward the point it compensates): where
    /// a glossy surface reflects its light.
    pub view: [f32; 3],
    pub _pad2: u32,
}

impl ShadingPoint {
    pub fn is_miss(&self) -> bool {
        self.triangle == MISS
    }
}

/// A node of the balanced kd-tree over a photon map (`vplgi_shared::photon_tree`): the box of
/// its photons, which are `count` consecutive photons of the map from `first`. Node i's children
/// are 2i + 1 and 2i + 2; the nodes whose children would lie past the array are the leaves. The
/// same bytes as `PhotonNode` in `types.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PhotonNode {
    pub lo: [f32; 3],
    pub first: u32,
    pub hi: [f32; 3],
    pub count: u32,
}

/// A node of the illumination cut (`vplgi_shared::illumination_cut`): its representative
/// photon's position and surface normal (the member nearest the centre of its box), its
/// radius r_p (the largest side of its box, at least `CutParams::min_radius`) and an irradiance:
/// Eq. 3's Ẽ_p in a node's estimate, the density estimate E_p in the cut final gathering reads.
/// The same bytes as `CutNode` in `types.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CutNode {
    pub position: [f32; 3],
    pub radius: f32,
    pub normal: [f32; 3],
    pub _pad0: u32,
    pub irradiance: [f32; 3],
    pub _pad1: u32,
}

/// A node of the photon tree as final gathering walks it: the box around the reach (spheres of
/// `GATHER_FALLBACK_REACH` r_j about p_j) of the cut nodes at or below it, and `slot`, the cut node's index in
/// the cut, or [`CUT_ABOVE`] for a node above the cut (walk its children). The same bytes as
/// `CutBound` in `types.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CutBound {
    pub lo: [f32; 3],
    pub slot: u32,
    pub hi: [f32; 3],
    pub _pad: u32,
}

/// [`CutBound::slot`] of a node above the cut.
pub const CUT_ABOVE: u32 = 0xffff_fffe;

/// A surface point: one end of a shadow ray (`visibility`'s rows and columns) and a point to
/// cluster. The same bytes as `Endpoint` in `types.wgsl` (two `vec4<f32>`, w = 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Endpoint {
    pub position: [f32; 3],
    pub _pad0: f32,
    pub normal: [f32; 3],
    pub _pad1: f32,
}

impl Endpoint {
    pub fn new(position: Vec3, normal: Vec3) -> Endpoint {
        Endpoint {
            position: position.to_array(),
            _pad0: 0.0,
            normal: normal.to_array(),
            _pad1: 0.0,
        }
    }

    /// A shading point as a shadow-ray end.
    pub fn of(sp: &ShadingPoint) -> Endpoint {
        Endpoint { position: sp.position, normal: sp.normal, ..Default::default() }
    }

    /// A VPL as a shadow-ray end.
    pub fn of_vpl(v: &Vpl) -> Endpoint {
        Endpoint { position: v.position, normal: v.normal, ..Default::default() }
    }

    /// The position.
    #[inline]
    pub fn p(&self) -> Vec3 {
        Vec3::from(self.position)
    }

    /// The unit normal.
    #[inline]
    pub fn n(&self) -> Vec3 {
        Vec3::from(self.normal)
    }
}

/// A light for indirect shading: one VPL, or one VPL cluster at its representative with its
/// members' summed flux. The same bytes as `VplLight` in `types.wgsl` (four `vec4<f32>`; the
/// position's w is `radius2`, the normal's w the bits of `exact`, the flux's w 0, the incoming
/// direction's w the bits of `material`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VplLight {
    pub position: [f32; 3],
    /// R² of the disk the light stands for (`vplgi_shared::disk`); for a polygon (`vplgi_shared::polygon`) the
    /// R² of a disk of its area; 0 for a point light.
    pub radius2: f32,
    pub normal: [f32; 3],
    /// How its exact form factor is taken: [`EXACT_DISK`] for a disk (`radius2` > 0,
    /// `vplgi_shared::disk::exact_geometry_term`), [`EXACT_POLYGON`] for a polygon whose outline is the
    /// light's [`LightOutline`] (`vplgi_shared::polygon::geometry_term`), 0 for Eq. 2 or a point.
    pub exact: u32,
    pub flux: [f32; 3],
    pub _pad2: f32,
    /// The lobe it emits through: [`Vpl::incoming`] and [`Vpl::material`] of the VPL it is, or of
    /// a cluster's representative.
    pub incoming: [f32; 3],
    pub material: u32,
}

/// [`VplLight::exact`] of a disk lit by its exact form factor.
pub const EXACT_DISK: u32 = 1;
/// [`VplLight::exact`] of a polygon light.
pub const EXACT_POLYGON: u32 = 2;

/// The most vertices of a polygon light's outline (`vplgi_shared::polygon`).
pub const OUTLINE_SIDES: usize = 8;

/// The outline of a polygon light (`vplgi_shared::polygon`), the same bytes as `LightOutline` in
/// `types.wgsl`: its vertices in space, counterclockwise about the light's normal, each with the
/// polygon's area in w; the vertices after the last have w = 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightOutline {
    pub vertices: [[f32; 4]; OUTLINE_SIDES],
}

impl LightOutline {
    /// The vertices in use.
    pub fn count(&self) -> usize {
        self.vertices.iter().take_while(|v| v[3] > 0.0).count()
    }

    /// The polygon's area (0 for no polygon).
    pub fn area(&self) -> f32 {
        self.vertices[0][3]
    }
}

impl VplLight {
    pub fn new(position: Vec3, normal: Vec3, flux: Vec3) -> VplLight {
        VplLight {
            position: position.to_array(),
            normal: normal.to_array(),
            flux: flux.to_array(),
            ..Default::default()
        }
    }

    /// The light of one VPL (or of a cluster whose representative it is) with `flux`.
    pub fn of(vpl: &Vpl, flux: Vec3) -> VplLight {
        VplLight {
            incoming: vpl.incoming,
            material: vpl.material,
            ..VplLight::new(vpl.position.into(), vpl.normal.into(), flux)
        }
    }

    /// Where its shadow rays end.
    pub fn endpoint(&self) -> Endpoint {
        Endpoint { position: self.position, normal: self.normal, ..Default::default() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    #[test]
    fn layouts_match_wgsl_rules() {
        assert_eq!(size_of::<Vpl>(), 64);
        assert_eq!(offset_of!(Vpl, normal), 16);
        assert_eq!(offset_of!(Vpl, flux), 32);
        assert_eq!(offset_of!(Vpl, incoming), 48);
        assert_eq!(size_of::<ShadingPoint>(), 80);
        assert_eq!(offset_of!(ShadingPoint, view), 64);
        assert_eq!(size_of::<VplLight>(), 64);
        assert_eq!(offset_of!(ShadingPoint, normal), 16);
        assert_eq!(offset_of!(ShadingPoint, albedo), 32);
        assert_eq!(offset_of!(ShadingPoint, emitted), 48);
    }
}

/// [`BsdfRecord::kind`] codes (`vplgi_shared::bsdf::Bsdf`'s variants).
pub const BSDF_DIFFUSE: u32 = 0;
pub const BSDF_MIRROR: u32 = 1;
pub const BSDF_ROUGH_CONDUCTOR: u32 = 2;
pub const BSDF_DIELECTRIC: u32 = 3;
pub const BSDF_THIN_DIELECTRIC: u32 = 4;
pub const BSDF_BLEND: u32 = 5;

/// One surface's BSDF as the GPU reads it (`vplgi_shared::bsdf::Bsdf::record`), the same bytes as
/// `BsdfRecord` in `common/bsdf.wgsl`. Fields a kind does not use are 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BsdfRecord {
    /// Diffuse and conductor reflectance (a blend's base colour).
    pub reflectance: [f32; 3],
    pub kind: u32,
    /// GGX roughness α (glTF's roughness squared).
    pub alpha: f32,
    /// Relative index of refraction, interior over exterior.
    pub eta: f32,
    /// A blend's share of the conductor.
    pub metallic: f32,
    pub pad: u32,
}
