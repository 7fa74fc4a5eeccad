//! Records the GPU reads, built on the host from the scene: the threaded BVH, per-triangle
//! shading data, materials, texture infos and light records. They cross between host and device
//! only (the CPU reference reads the scene directly), and are laid out as their WGSL structs
//! (`shaders/common/`), which a table-driven test in vplgi-gpu checks against naga's layouter.

use bytemuck::{Pod, Zeroable};

/// The node index after the last node of the preorder: the traversal is over (`BVH_END` in
/// bvh.wgsl).
pub const END: u32 = u32::MAX;
/// Low bits of a BVH leaf's link word that hold its triangle count (`LEAF_COUNT_BITS`;
/// `vplgi_gpu::bvh::BvhNode`).
pub const LEAF_COUNT_BITS: u32 = 4;

/// A triangle as the WGSL traversal reads it (`BvhTri`): its vertices, v0 with the scene
/// triangle index in w. Vertices rather than edges: the watertight test in bvh.wgsl needs the
/// exact shared vertices.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BvhTri {
    pub v0: [f32; 4],
    pub v1: [f32; 4],
    pub v2: [f32; 4],
}

/// Per-triangle shading data (`SceneTri` in `shaders/common/types.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SceneTri {
    pub ng: [f32; 4],
    pub n0: [f32; 4],
    pub n1: [f32; 4],
    pub n2: [f32; 4],
    pub uv01: [f32; 4],
    pub uv2: [f32; 4],
}

/// `Material` in `types.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterial {
    pub base_color: [f32; 4],
    pub emission: [f32; 4],
    /// The material's BSDF with reflectance 0: a hit puts its own colour there.
    pub bsdf: crate::BsdfRecord,
}

/// `TextureInfo` in `types.wgsl`: where a texture's texels start in the texel words, and how
/// they are stored.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub format: u32,
}

/// A texture whose every texel is exactly an 8-bit sRGB code's linear value (what 8-bit images
/// decode to) is stored as the codes, one word per texel, and decoded through the table at the
/// start of the texel words; any other texture as three f32 words per texel.
pub const TEXELS_SRGB8: u32 = 0;
pub const TEXELS_F32: u32 = 1;

/// `Emitter` in `shaders/common/lights.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Emitter {
    pub v0: [f32; 4],
    pub e1: [f32; 4],
    pub e2: [f32; 4],
    pub normal: [f32; 4],
    pub radiance: [f32; 4],
}

/// `LightGroup` in `lights.wgsl`: a run of consecutive emitters with the bounds direct light uses
/// to choose among groups at a shading point (`vplgi_types::light_groups`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct LightGroup {
    /// Bounding sphere of the group's triangles: centre, radius.
    pub sphere: [f32; 4],
    /// Normal cone: unit axis and the cosine of its half-angle, or axis zero and
    /// [`crate::light_groups::ANY_ORIENTATION`] when the normals spread over more than a hemisphere.
    pub cone: [f32; 4],
    /// x: emitted power (mean of RGB, W); y: the sum of its emitters' realised probabilities in the
    /// power table; z: that table's CDF before its first emitter; w unused.
    pub power: [f32; 4],
    /// First emitter, emitter count, unused, unused.
    pub range: [u32; 4],
}

/// `Punctual` in `lights.wgsl`. Point: position, w [`PUNCTUAL_POINT`]. Spot: position, w
/// [`PUNCTUAL_SPOT`]; direction, w cos_inner; intensity, w cos_outer. Directional: the centre of
/// the disk its particles start from, w [`PUNCTUAL_DIRECTIONAL`]; the direction it travels in, w
/// the disk's radius; irradiance.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Punctual {
    pub position: [f32; 4],
    pub direction: [f32; 4],
    pub intensity: [f32; 4],
}

/// The kinds of [`Punctual`] light, in its `position.w`.
pub const PUNCTUAL_POINT: f32 = 0.0;
pub const PUNCTUAL_SPOT: f32 = 1.0;
pub const PUNCTUAL_DIRECTIONAL: f32 = 2.0;
