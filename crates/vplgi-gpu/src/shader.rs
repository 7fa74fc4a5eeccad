//! WGSL sources. WGSL has no `#include`: a stage's module is the shared files of
//! `shaders/common/` followed by the stage file. Every composed module is validated by naga in a
//! CPU-only test.

use crate::scene::page_len;

const RNG: &str = include_str!("../../../shaders/common/rng.wgsl");
const BVH: &str = include_str!("../../../shaders/common/bvh.wgsl");
const TYPES: &str = include_str!("../../../shaders/common/types.wgsl");
const LIGHTS: &str = include_str!("../../../shaders/common/lights.wgsl");
const SAMPLING: &str = include_str!("../../../shaders/common/sampling.wgsl");
const SURFACE: &str = include_str!("../../../shaders/common/surface.wgsl");

/// Shared WGSL files by name.
pub const COMMON: &[(&str, &str)] = &[
    ("common/types.wgsl", TYPES),
    ("common/rng.wgsl", RNG),
    ("common/bvh.wgsl", BVH),
    ("common/lights.wgsl", LIGHTS),
    ("common/sampling.wgsl", SAMPLING),
    ("common/surface.wgsl", SURFACE),
];

/// Stage files: (name, source, the common files it includes, in order).
pub const STAGES: &[(&str, &str, &[&str])] = &[
    ("rng_streams.wgsl", include_str!("../../../shaders/rng_streams.wgsl"), &["common/types.wgsl", "common/rng.wgsl"]),
    (
        "shading_points.wgsl",
        include_str!("../../../shaders/shading_points.wgsl"),
        &["common/types.wgsl", "common/rng.wgsl", "common/bvh.wgsl", "common/surface.wgsl"],
    ),
    (
        "trace_vpls.wgsl",
        include_str!("../../../shaders/trace_vpls.wgsl"),
        &["common/types.wgsl", "common/rng.wgsl", "common/bvh.wgsl", "common/surface.wgsl", "common/sampling.wgsl", "common/lights.wgsl"],
    ),
    ("visibility.wgsl", include_str!("../../../shaders/visibility.wgsl"), &["common/types.wgsl", "common/bvh.wgsl"]),
    ("cluster.wgsl", include_str!("../../../shaders/cluster.wgsl"), &["common/types.wgsl"]),
    ("frame.wgsl", include_str!("../../../shaders/frame.wgsl"), &["common/types.wgsl"]),
    ("scan.wgsl", include_str!("../../../shaders/scan.wgsl"), &[]),
    ("shade.wgsl", include_str!("../../../shaders/shade.wgsl"), &["common/types.wgsl", "common/rng.wgsl", "common/bvh.wgsl", "common/lights.wgsl"]),
];

/// The composed source of stage `name` (a file name from [`STAGES`]): its common files, then
/// the stage file.
pub fn compose(name: &str) -> String {
    let (_, stage, includes) = STAGES.iter().find(|(n, _, _)| *n == name).unwrap_or_else(|| panic!("unknown stage shader {name}"));
    let mut src = String::new();
    for inc in includes.iter() {
        let text = COMMON.iter().find(|(n, _)| n == inc).map(|(_, t)| *t).unwrap_or_else(|| panic!("unknown common shader {inc}"));
        src.push_str(&format!("// ---- {inc}\n{text}\n"));
    }
    src.push_str(&format!("// ---- {name}\n{stage}\n"));
    src
}

/// A compute pipeline for `entry` of stage `name`, with the layout derived from the shader.
pub fn pipeline(device: &wgpu::Device, name: &str, entry: &str) -> wgpu::ComputePipeline {
    pipelines(device, name, &[entry]).remove(0)
}

/// The pipeline of a stage entry that traverses the BVH, in two variants. The BVH's nodes and
/// triangles may each spill into a second binding (`bvh_node`/`bvh_tri` in bvh.wgsl), but
/// branching between the pages on every node costs lavapipe about a quarter of its traversal
/// throughput (`examples/bvh_choice.rs`: 0.10 against 0.13 Mrays/s), and almost every scene fits
/// one page. So the pipeline every scene starts with is compiled with `BVH_PAGED = false`, which
/// folds the branch away, and the paged variant is compiled the first time a scene needs it.
pub struct RayPipeline {
    name: &'static str,
    entry: &'static str,
    flat: wgpu::ComputePipeline,
    paged: std::sync::OnceLock<wgpu::ComputePipeline>,
}

impl RayPipeline {
    pub fn new(device: &wgpu::Device, name: &'static str, entry: &'static str) -> RayPipeline {
        RayPipeline { name, entry, flat: compile(device, name, &[entry], false).remove(0), paged: std::sync::OnceLock::new() }
    }

    /// The variant for `scene`.
    pub fn get(&self, device: &wgpu::Device, scene: &crate::scene::GpuScene) -> &wgpu::ComputePipeline {
        if scene.bvh_paged {
            self.paged.get_or_init(|| compile(device, self.name, &[self.entry], true).remove(0))
        } else {
            &self.flat
        }
    }
}

/// The page-size overrides of the paged scene arrays a stage reads, from the device's limits,
/// and whether the BVH arrays may use their second pages.
fn page_constants(device: &wgpu::Device, name: &str, bvh_paged: bool) -> Vec<(&'static str, f64)> {
    let includes = STAGES.iter().find(|(n, _, _)| *n == name).map(|(_, _, i)| *i).unwrap_or(&[]);
    let mut c = Vec::new();
    if includes.contains(&"common/bvh.wgsl") {
        c.push(("BVH_PAGED", if bvh_paged { 1.0 } else { 0.0 }));
        c.push(("BVH_NODE_PAGE", page_len::<crate::bvh::BvhNode>(device).min(u32::MAX as u64) as f64));
        c.push(("BVH_TRI_PAGE", page_len::<crate::bvh::BvhTri>(device).min(u32::MAX as u64) as f64));
    }
    if includes.contains(&"common/surface.wgsl") {
        c.push(("SCENE_TRI_PAGE", page_len::<crate::scene::SceneTri>(device).min(u32::MAX as u64) as f64));
        c.push(("TEXEL_PAGE", page_len::<u32>(device).min(u32::MAX as u64) as f64));
    }
    c
}

/// One pipeline per entry point of stage `name`, compiled from one module. Each layout is
/// derived from the bindings its entry point uses.
pub fn pipelines(device: &wgpu::Device, name: &str, entries: &[&str]) -> Vec<wgpu::ComputePipeline> {
    compile(device, name, entries, true)
}

fn compile(device: &wgpu::Device, name: &str, entries: &[&str], bvh_paged: bool) -> Vec<wgpu::ComputePipeline> {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(compose(name).into()) });
    let constants = page_constants(device, name, bvh_paged);
    entries
        .iter()
        .map(|entry| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
                cache: None,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every stage, composed with the common files, parses and validates with naga: no GPU needed.
    #[test]
    fn every_wgsl_file_validates() {
        for (name, _, _) in STAGES {
            let src = compose(name);
            let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        }
    }

    /// Size and member offsets of a WGSL struct, from naga's layouter.
    fn wgsl_layout(stage: &str, name: &str) -> (u32, Vec<(String, u32)>) {
        let src = compose(stage);
        let module = naga::front::wgsl::parse_str(&src).expect("parses");
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).expect("layout");
        for (handle, ty) in module.types.iter() {
            if ty.name.as_deref() == Some(name) {
                if let naga::TypeInner::Struct { members, span } = &ty.inner {
                    assert_eq!(layouter[handle].size, *span);
                    return (*span, members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect());
                }
            }
        }
        panic!("struct {name} not found in {stage}");
    }

    /// Every struct shared between Rust and WGSL has the same size and field offsets on both
    /// sides.
    #[test]
    fn shared_structs_match_their_wgsl_layout() {
        use std::mem::{offset_of, size_of};
        use vplgi_types::{ShadingPoint, Vpl};
        let check = |stage: &str, name: &str, size: usize, offsets: &[(&str, usize)]| {
            let (wsize, members) = wgsl_layout(stage, name);
            assert_eq!(wsize as usize, size, "{name}: WGSL size {wsize}, Rust size {size}");
            for (field, off) in offsets {
                let m = members.iter().find(|(n, _)| n == field).unwrap_or_else(|| panic!("{name}.{field} missing in WGSL"));
                assert_eq!(m.1 as usize, *off, "{name}.{field}: WGSL offset {}, Rust offset {off}", m.1);
            }
        };
        check(
            "shading_points.wgsl",
            "ShadingPoint",
            size_of::<ShadingPoint>(),
            &[
                ("position", offset_of!(ShadingPoint, position)),
                ("pixel", offset_of!(ShadingPoint, pixel)),
                ("normal", offset_of!(ShadingPoint, normal)),
                ("triangle", offset_of!(ShadingPoint, triangle)),
                ("albedo", offset_of!(ShadingPoint, albedo)),
                ("emitted", offset_of!(ShadingPoint, emitted)),
            ],
        );
        check(
            "shading_points.wgsl",
            "Vpl",
            size_of::<Vpl>(),
            &[
                ("position", offset_of!(Vpl, position)),
                ("path", offset_of!(Vpl, path)),
                ("normal", offset_of!(Vpl, normal)),
                ("bounce", offset_of!(Vpl, bounce)),
                ("flux", offset_of!(Vpl, flux)),
            ],
        );
        use crate::scene::{GpuMaterial, SceneTri, TextureInfo};
        check(
            "shading_points.wgsl",
            "SceneTri",
            size_of::<SceneTri>(),
            &[("ng", 0), ("n0", offset_of!(SceneTri, n0)), ("uv01", offset_of!(SceneTri, uv01)), ("uv2", offset_of!(SceneTri, uv2))],
        );
        check("shading_points.wgsl", "Material", size_of::<GpuMaterial>(), &[("base_color", 0), ("emission", offset_of!(GpuMaterial, emission))]);
        check("shading_points.wgsl", "TextureInfo", size_of::<TextureInfo>(), &[("offset", 0), ("width", 4), ("height", 8), ("format", 12)]);
        use crate::bvh::{BvhNode, BvhTri};
        check("visibility.wgsl", "BvhTri", size_of::<BvhTri>(), &[("v0", 0), ("v1", offset_of!(BvhTri, v1)), ("v2", offset_of!(BvhTri, v2))]);
        check(
            "visibility.wgsl",
            "BvhNode",
            size_of::<BvhNode>(),
            &[("min", 0), ("skip", offset_of!(BvhNode, skip)), ("max", offset_of!(BvhNode, max)), ("leaf", offset_of!(BvhNode, leaf))],
        );
        use crate::lights::{Emitter, Punctual};
        check(
            "shade.wgsl",
            "Emitter",
            size_of::<Emitter>(),
            &[("v0", 0), ("e1", 16), ("normal", offset_of!(Emitter, normal)), ("radiance", offset_of!(Emitter, radiance))],
        );
        check("shade.wgsl", "Punctual", size_of::<Punctual>(), &[("position", 0), ("direction", 16), ("intensity", offset_of!(Punctual, intensity))]);
        use crate::shade::VplLight;
        check("shade.wgsl", "VplLight", size_of::<VplLight>(), &[("position", 0), ("normal", 16), ("flux", offset_of!(VplLight, flux))]);
        use crate::visibility::Endpoint;
        check("visibility.wgsl", "Endpoint", size_of::<Endpoint>(), &[("position", 0), ("normal", offset_of!(Endpoint, normal))]);
    }
}
