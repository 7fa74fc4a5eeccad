//! A scene on the device: BVH, per-triangle shading data, materials and textures.

use crate::buffers::storage;
use crate::bvh::{self, BvhTri};
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

/// Device buffers of a scene, uploaded once.
pub struct GpuScene {
    pub bvh_nodes: wgpu::Buffer,
    pub bvh_tris: wgpu::Buffer,
    pub scene_tris: wgpu::Buffer,
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
        for (what, bytes) in [
            ("the BVH nodes", (arrays.nodes.len() * 48) as u64),
            ("the BVH triangles", (arrays.tris.len() * std::mem::size_of::<BvhTri>()) as u64),
            ("the triangle shading data", (tris.len() * std::mem::size_of::<SceneTri>()) as u64),
            ("the texels", (texels.len() * 16) as u64),
        ] {
            if bytes > limit {
                return Err(GpuError::TooLarge { what: what.into(), needed: bytes, limit });
            }
        }
        Ok(GpuScene {
            bvh_nodes: storage(device, "bvh nodes", &arrays.nodes),
            bvh_tris: storage(device, "bvh tris", &arrays.tris),
            scene_tris: storage(device, "scene tris", &tris),
            materials: storage(device, "materials", &materials),
            texture_infos: storage(device, "texture infos", &infos),
            texels: storage(device, "texels", &texels),
            eps: scene.ray_epsilon(),
            camera: scene.camera,
            triangles: scene.triangle_count(),
        })
    }
}
