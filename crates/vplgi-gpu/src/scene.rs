//! A scene on the device: BVH, per-triangle shading data, materials and textures.

use crate::buffers::storage;
use crate::bvh;
use crate::GpuError;
use bytemuck::{Pod, Zeroable};
use vplgi_scene::Scene;
use vplgi_types::MISS;

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
}

/// `TextureInfo` in `types.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub pad: u32,
}

/// Device buffers of a scene, uploaded once. The three arrays that grow with the triangle count
/// are paged over two bindings each (`_hi` holds what does not fit the first; see
/// `shaders/common/bvh.wgsl`), so a scene may need up to twice the storage-binding size per array.
pub struct GpuScene {
    pub bvh_nodes: wgpu::Buffer,
    pub bvh_nodes_hi: wgpu::Buffer,
    pub bvh_tris: wgpu::Buffer,
    pub bvh_tris_hi: wgpu::Buffer,
    pub scene_tris: wgpu::Buffer,
    pub scene_tris_hi: wgpu::Buffer,
    pub materials: wgpu::Buffer,
    pub texture_infos: wgpu::Buffer,
    pub texels: wgpu::Buffer,
    /// Ray offset, identical to the CPU's ([`Scene::ray_epsilon`]).
    pub eps: f32,
    pub camera: vplgi_scene::Camera,
    pub triangles: usize,
}

impl GpuScene {
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
                base_color: [m.base_color.x, m.base_color.y, m.base_color.z, f32::from_bits(m.base_color_texture.unwrap_or(MISS))],
                emission: [m.emission.x, m.emission.y, m.emission.z, 0.0],
            })
            .collect();
        let mut infos = Vec::new();
        let mut texels: Vec<[f32; 4]> = Vec::new();
        for t in &scene.textures {
            infos.push(TextureInfo { offset: texels.len() as u32, width: t.width, height: t.height, pad: 0 });
            texels.extend(t.texels.iter().map(|c| [c.x, c.y, c.z, 1.0]));
        }
        let limit = device.limits().max_storage_buffer_binding_size;
        let texel_bytes = (texels.len() * 16) as u64;
        if texel_bytes > limit {
            return Err(GpuError::TooLarge { what: "the texels".into(), needed: texel_bytes, limit });
        }
        let (bvh_nodes, bvh_nodes_hi) = paged(device, "bvh nodes", &arrays.nodes)?;
        let (bvh_tris, bvh_tris_hi) = paged(device, "bvh tris", &arrays.tris)?;
        let (scene_tris, scene_tris_hi) = paged(device, "scene tris", &tris)?;
        Ok(GpuScene {
            bvh_nodes,
            bvh_nodes_hi,
            bvh_tris,
            bvh_tris_hi,
            scene_tris,
            scene_tris_hi,
            materials: storage(device, "materials", &materials),
            texture_infos: storage(device, "texture infos", &infos),
            texels: storage(device, "texels", &texels),
            eps: scene.ray_epsilon(),
            camera: scene.camera,
            triangles: scene.triangle_count(),
        })
    }
}

/// Elements of `T` per page: as many as one storage binding of this device holds. The shaders'
/// page-size overrides are set from the same function (`shader::pipelines`).
pub fn page_len<T>(device: &wgpu::Device) -> u64 {
    device.limits().max_storage_buffer_binding_size / std::mem::size_of::<T>() as u64
}

/// `data` over two bindings: the first page, then the rest (at most one more page).
fn paged<T: bytemuck::Pod>(device: &wgpu::Device, label: &str, data: &[T]) -> Result<(wgpu::Buffer, wgpu::Buffer), GpuError> {
    let page = page_len::<T>(device) as usize;
    if data.len() > 2 * page {
        let size = std::mem::size_of::<T>() as u64;
        return Err(GpuError::TooLarge { what: format!("{label} (two pages)"), needed: data.len() as u64 * size, limit: 2 * page as u64 * size });
    }
    let split = data.len().min(page);
    Ok((storage(device, label, &data[..split]), storage(device, label, &data[split..])))
}
