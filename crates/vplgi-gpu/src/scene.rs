//! A scene on the device: BVH, per-triangle shading data, materials and textures.

use crate::buffers::storage;
use crate::bvh;
use crate::lights::GpuLights;
use crate::GpuError;
use vplgi_scene::Scene;
pub use vplgi_types::device::{GpuMaterial, SceneTri, TextureInfo, TEXELS_F32, TEXELS_SRGB8};
use vplgi_types::MISS;

/// Texel words are paged over this many storage bindings (`texels`, `texels_1` ..), and the
/// shaders' `texel_word` reads them with the `TEXEL_PAGE` override as page size.
pub const TEXEL_PAGES: usize = 4;

/// Pages of per-triangle shading data (`scene_tris`, `scene_tris_1` ..; `scene_tri` in
/// `surface.wgsl`): at 96 bytes per triangle, twice the BVH arrays' size per triangle, so it gets
/// twice their pages and the BVH arrays are the first to run out.
pub const SCENE_TRI_PAGES: usize = 4;

/// The texel words of all textures: the 256-entry decode table (f32 bits), then each texture's
/// texels, and their infos.
pub fn texel_words(scene: &Scene) -> (Vec<u32>, Vec<TextureInfo>) {
    let table = vplgi_scene::srgb8_table();
    let code: std::collections::HashMap<u32, u32> =
        table.iter().enumerate().map(|(i, v)| (v.to_bits(), i as u32)).collect();
    let mut words: Vec<u32> = table.iter().map(|v| v.to_bits()).collect();
    let mut infos = Vec::new();
    for t in &scene.textures {
        let codes: Option<Vec<u32>> = t
            .texels
            .iter()
            .map(|c| {
                Some(
                    code.get(&c.x.to_bits())?
                        | code.get(&c.y.to_bits())? << 8
                        | code.get(&c.z.to_bits())? << 16,
                )
            })
            .collect();
        let format = if codes.is_some() { TEXELS_SRGB8 } else { TEXELS_F32 };
        infos.push(TextureInfo {
            offset: words.len() as u32,
            width: t.width,
            height: t.height,
            format,
        });
        match codes {
            Some(c) => words.extend(c),
            None => words.extend(
                t.texels.iter().flat_map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()]),
            ),
        }
    }
    (words, infos)
}

/// Device buffers of a scene, uploaded once. Arrays that grow with the scene are read at random
/// (by traversal, by hit triangle, by texel) and so are paged over several bindings, read
/// through WGSL accessors whose page size is an override set from the device limit: BVH nodes
/// and BVH triangles over two (`_hi` holds what does not fit the first; see
/// `shaders/common/bvh.wgsl`), the per-triangle shading data (twice their size) over
/// [`SCENE_TRI_PAGES`], texel words over [`TEXEL_PAGES`] (`shaders/common/surface.wgsl`).
pub struct GpuScene {
    /// Whether the BVH's nodes or triangles spill into their second binding
    /// ([`crate::shader::RayPipeline`]).
    pub bvh_paged: bool,
    /// Some material has a base-colour texture: ray pipelines keep their texture lookup.
    pub textured: bool,
    pub bvh_nodes: wgpu::Buffer,
    pub bvh_nodes_hi: wgpu::Buffer,
    pub bvh_tris: wgpu::Buffer,
    pub bvh_tris_hi: wgpu::Buffer,
    /// The dequantization of the nodes' boxes ([`bvh::BvhFrame`]).
    pub bvh_frame: wgpu::Buffer,
    pub scene_tris: [wgpu::Buffer; SCENE_TRI_PAGES],
    pub materials: wgpu::Buffer,
    /// Each material's BSDF in white (`Surface::with_colour(1)`), for `shade`'s lobes.
    pub lobes: wgpu::Buffer,
    /// Some material is glossy (`Surface::is_glossy`): `shade` evaluates lobes.
    pub glossy: bool,
    /// Some material is a mirror or glass: the scene has caustics.
    pub specular: bool,
    pub texture_infos: wgpu::Buffer,
    /// [`TEXEL_PAGES`] pages of texel words ([`texel_words`]).
    pub texels: [wgpu::Buffer; TEXEL_PAGES],
    /// Ray offset, identical to the CPU's ([`Scene::ray_epsilon`]).
    pub eps: f32,
    pub camera: vplgi_scene::Camera,
    /// The host's light tables, whose reflective shadow maps are sized per frame (`--rsm-size`).
    pub sampler: vplgi_scene::lights::LightSampler,
    /// The light tables (light particles and direct light).
    pub lights: GpuLights,
}

/// Binding number of the scene's first array in group 0 (`shaders/common/scene.wgsl`); a stage's
/// own bindings stay below it.
pub const FIRST_SCENE_BINDING: u32 = 32;

/// Where a scene binding's buffer is in a [`GpuScene`].
pub type SceneBuffer = fn(&GpuScene) -> &wgpu::Buffer;

/// The scene's arrays in the binding order of `scene.wgsl`, by their WGSL names (a test checks
/// the two against each other).
pub const SCENE_BINDINGS: [(&str, SceneBuffer); 21] = [
    ("bvh_nodes", |s| &s.bvh_nodes),
    ("bvh_nodes_hi", |s| &s.bvh_nodes_hi),
    ("bvh_tris", |s| &s.bvh_tris),
    ("bvh_tris_hi", |s| &s.bvh_tris_hi),
    ("scene_tris", |s| &s.scene_tris[0]),
    ("scene_tris_1", |s| &s.scene_tris[1]),
    ("scene_tris_2", |s| &s.scene_tris[2]),
    ("scene_tris_3", |s| &s.scene_tris[3]),
    ("materials", |s| &s.materials),
    ("texture_infos", |s| &s.texture_infos),
    ("texels", |s| &s.texels[0]),
    ("texels_1", |s| &s.texels[1]),
    ("texels_2", |s| &s.texels[2]),
    ("texels_3", |s| &s.texels[3]),
    ("light_counts", |s| &s.lights.counts),
    ("emitters", |s| &s.lights.emitters),
    ("area_table", |s| &s.lights.area_table),
    ("all_table", |s| &s.lights.all_table),
    ("punctual", |s| &s.lights.punctual),
    ("light_groups", |s| &s.lights.groups),
    ("bvh_frame", |s| &s.bvh_frame),
];

impl GpuScene {
    /// [`Self::lobes`] where some material is glossy, for `ShadeInputs::lobes`.
    pub fn glossy_lobes(&self) -> Option<&wgpu::Buffer> {
        self.glossy.then_some(&self.lobes)
    }

    /// The scene's arrays among the bindings `used` (those a pipeline reads).
    pub fn bindings(&self, used: &[u32]) -> Vec<(u32, wgpu::BufferBinding<'_>)> {
        (FIRST_SCENE_BINDING..)
            .zip(SCENE_BINDINGS)
            .filter(|(n, _)| used.contains(n))
            .map(|(n, (_, buffer))| (n, buffer(self).as_entire_buffer_binding()))
            .collect()
    }

    /// Uploads the scene: BVH, shading data, materials, texels and light tables.
    pub fn new(device: &wgpu::Device, scene: &Scene) -> Result<GpuScene, GpuError> {
        let arrays = bvh::build(scene)?;
        let tris: Vec<SceneTri> = (0..scene.triangle_count())
            .map(|t| {
                let [a, b, c] = scene.indices[t];
                let n = |v: u32| {
                    let n = scene.normals[v as usize];
                    [n.x, n.y, n.z, 0.0]
                };
                let uv = |v: u32| scene.uvs[v as usize];
                let g = scene.geometric_normal(t);
                SceneTri {
                    ng: [g.x, g.y, g.z, f32::from_bits(scene.material_ids[t])],
                    n0: n(a),
                    n1: n(b),
                    n2: n(c),
                    uv01: [uv(a).x, uv(a).y, uv(b).x, uv(b).y],
                    uv2: [uv(c).x, uv(c).y, 0.0, 0.0],
                }
            })
            .collect();
        let materials: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .map(|m| GpuMaterial {
                base_color: [
                    m.base_color.x,
                    m.base_color.y,
                    m.base_color.z,
                    f32::from_bits(m.base_color_texture.unwrap_or(MISS)),
                ],
                emission: [m.emission.x, m.emission.y, m.emission.z, 0.0],
                bsdf: m.surface.with_colour(glam::Vec3::ZERO).record(),
            })
            .collect();
        let lobes: Vec<vplgi_types::BsdfRecord> = scene
            .materials
            .iter()
            .map(|m| m.surface.with_colour(glam::Vec3::ONE).record())
            .collect();
        let sampler = vplgi_scene::lights::LightSampler::new(scene);
        let (words, infos) = texel_words(scene);
        let texels = pages::<u32, TEXEL_PAGES>(device, "texel words", &words)?;
        let bvh_paged = arrays.nodes.len() as u64 > page_len::<bvh::BvhNode>(device)
            || arrays.tris.len() as u64 > page_len::<bvh::BvhTri>(device);
        let (bvh_nodes, bvh_nodes_hi) = paged(device, "bvh nodes", &arrays.nodes)?;
        let (bvh_tris, bvh_tris_hi) = paged(device, "bvh tris", &arrays.tris)?;
        let scene_tris = pages::<SceneTri, SCENE_TRI_PAGES>(device, "scene tris", &tris)?;
        Ok(GpuScene {
            bvh_paged,
            textured: scene.materials.iter().any(|m| m.base_color_texture.is_some()),
            bvh_nodes,
            bvh_nodes_hi,
            bvh_tris,
            bvh_tris_hi,
            bvh_frame: storage(device, "bvh frame", &[arrays.frame]),
            scene_tris,
            materials: storage(device, "materials", &materials),
            lobes: storage(device, "lobes", &lobes),
            glossy: scene.materials.iter().any(|m| m.surface.is_glossy()),
            specular: scene.has_specular(),
            texture_infos: storage(device, "texture infos", &infos),
            texels,
            eps: scene.ray_epsilon(),
            camera: scene.camera,
            lights: GpuLights::new(device, scene, &sampler),
            sampler,
        })
    }
}

/// Elements of `T` per page: as many as one storage binding of this device holds. The shaders'
/// page-size overrides are set from the same function (`shader::pipelines`).
pub fn page_len<T>(device: &wgpu::Device) -> u64 {
    device.limits().max_storage_buffer_binding_size / std::mem::size_of::<T>() as u64
}

/// `data` over two bindings: the first page, then the rest (at most one more page).
fn paged<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &str,
    data: &[T],
) -> Result<(wgpu::Buffer, wgpu::Buffer), GpuError> {
    let [lo, hi] = pages::<T, 2>(device, label, data)?;
    Ok((lo, hi))
}

/// `data` over `N` bindings of [`page_len`] elements each (unused pages hold one zeroed
/// element).
fn pages<T: bytemuck::Pod, const N: usize>(
    device: &wgpu::Device,
    label: &str,
    data: &[T],
) -> Result<[wgpu::Buffer; N], GpuError> {
    let page = (page_len::<T>(device) as usize).max(1);
    if data.len() > N * page {
        let size = std::mem::size_of::<T>() as u64;
        return Err(GpuError::TooLarge {
            what: format!("bytes of {label} in {N} storage bindings"),
            needed: data.len() as u64 * size,
            limit: (N * page) as u64 * size,
        });
    }
    Ok(std::array::from_fn(|i| {
        storage(device, label, &data[(i * page).min(data.len())..((i + 1) * page).min(data.len())])
    }))
}
