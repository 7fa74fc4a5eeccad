//! WGSL sources. WGSL has no `#include`: a stage's module is the shared files of
//! `shaders/common/` followed by the stage file. Every composed module is validated by naga in a
//! CPU-only test.
//!
//! The sources are compiled in. A kernel author may replace any of them at run time with
//! [`use_sources_from`] (`vplgi verify --shaders DIR`), so an edited shader is tested without
//! rebuilding vplgi.

use crate::scene::page_len;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// Sources read from a directory, by the names of [`COMMON`] and [`STAGES`]; set once per process.
static REPLACED: OnceLock<BTreeMap<&'static str, String>> = OnceLock::new();

/// Why shader sources from a directory cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    #[error("{path}: {message}")]
    Read { path: PathBuf, message: String },
    #[error(
        "{dir} holds none of vplgi's shader files (expected e.g. shade.wgsl, common/rng.wgsl)"
    )]
    Empty { dir: PathBuf },
    #[error("{file} does not compile as part of {stage}:\n{message}")]
    Invalid { file: String, stage: String, message: String },
    #[error("shader sources were already chosen for this process")]
    AlreadySet,
}

/// A shader file read from a directory instead of the compiled-in copy.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ReplacedSource {
    /// The name under `shaders/` (`shade.wgsl`, `common/rng.wgsl`).
    pub name: &'static str,
    pub path: PathBuf,
    /// Whether its text differs from the compiled-in copy.
    pub differs: bool,
}

/// Reads every known shader file present in `dir` (laid out like `shaders/`: stage files at the
/// top, shared files in `common/`) and uses them instead of the compiled-in copies for every
/// pipeline this process builds afterwards. Every stage module is validated by naga first, so a
/// broken file is an error naming it, never a panic inside wgpu. Call before building kernels.
pub fn use_sources_from(dir: &Path) -> Result<Vec<ReplacedSource>, SourceError> {
    if !dir.is_dir() {
        return Err(SourceError::Read {
            path: dir.to_path_buf(),
            message: "not a directory".into(),
        });
    }
    let known = COMMON.iter().map(|(n, t)| (*n, *t)).chain(STAGES.iter().map(|(n, t, _)| (*n, *t)));
    let mut map = BTreeMap::new();
    let mut replaced = Vec::new();
    for (name, builtin) in known {
        let path = dir.join(name);
        if !path.exists() {
            continue;
        }
        let text = std::fs::read_to_string(&path)
            .map_err(|e| SourceError::Read { path: path.clone(), message: e.to_string() })?;
        replaced.push(ReplacedSource { name, path, differs: text != builtin });
        map.insert(name, text);
    }
    if map.is_empty() {
        return Err(SourceError::Empty { dir: dir.to_path_buf() });
    }
    for (stage, _, includes) in STAGES {
        let touched: Vec<&str> = std::iter::once(*stage)
            .chain(includes.iter().copied())
            .filter(|n| map.contains_key(n))
            .collect();
        if touched.is_empty() {
            continue;
        }
        let src = compose_from(stage, &map);
        validate(&src).map_err(|message| SourceError::Invalid {
            file: touched.join(", "),
            stage: stage.to_string(),
            message,
        })?;
    }
    REPLACED.set(map).map_err(|_| SourceError::AlreadySet)?;
    Ok(replaced)
}

/// Parses and validates a composed module; the error is naga's report, with the offending lines.
fn validate(src: &str) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(src).map_err(|e| e.emit_to_string(src))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| e.emit_to_string(src))?;
    Ok((module, info))
}

/// Codes of `mode` in `shade.wgsl`'s parameters: where a shading point's visibility comes from.
pub const SHADE_OWN_ROW: u32 = 0;
pub const SHADE_FUZZY: u32 = 1;
/// Shading points one invocation of `shade_lights` sums the lights for: each light is loaded
/// once for all of them (`shade.wgsl` says why that matters on lavapipe).
pub const SHADE_POINTS: u32 = 4;
/// Points folded by one invocation of the clustering's reductions (`bounds`, `outcome_counts` in
/// `cluster_points.wgsl`) before its atomics: an atomic is a locked instruction per lane on
/// lavapipe.
pub const REDUCE_ITEMS: u32 = 64;
/// Consecutive rows whose same word consecutive invocations of `visibility` compute
/// (`visibility.wgsl` says why).
pub const VISIBILITY_ROW_LANES: u32 = 8;
/// Codes of `fuzzy` in the clustering passes' parameters (`common/cluster.wgsl`): how a point's F clusters are weighted.
pub const WEIGHTS_PLAIN_MEAN: u32 = 0;
pub const WEIGHTS_INVERSE_DISTANCE: u32 = 1;
/// Codes of the clustering metric (`METRIC`, an override of `cluster_assign.wgsl`).
pub const METRIC_EQ7: u32 = 0;
pub const METRIC_WARD: u32 = 1;
/// Codes of `representative` in the clustering passes' parameters: which member stands for a cluster.
pub const REPRESENTATIVE_NEAREST: u32 = 0;
pub const REPRESENTATIVE_MIN_ERROR: u32 = 1;

/// Constants by WGSL name, with their Rust values.
type Named<T> = Vec<(&'static str, T)>;

/// The constants WGSL shares with Rust: the integers, then the floats.
fn shared_constants() -> (Named<u32>, Named<f32>) {
    use vplgi_types::Stream;
    let u = vec![
        ("MISS", vplgi_types::MISS),
        ("MAX_F", vplgi_types::config::MAX_F),
        ("EMISSION_STRATA", vplgi_types::params::EMISSION_STRATA),
        ("STREAM_LIGHT_PATH", Stream::LightPath as u32),
        ("STREAM_DIRECT", Stream::Direct as u32),
        ("STREAM_CAMERA", Stream::Camera as u32),
        ("STREAM_CLUSTER", Stream::Cluster as u32),
        ("STREAM_BIAS", Stream::Bias as u32),
        ("STREAM_SCRAMBLE", Stream::Scramble as u32),
        ("STREAM_SEEDING", Stream::Seeding as u32),
        ("STREAM_GATHER", Stream::Gather as u32),
        ("STREAM_SPECULAR", Stream::Specular as u32),
        ("STREAM_RSM_SPECULAR", Stream::RsmSpecular as u32),
        ("BVH_END", crate::bvh::END),
        ("LEAF_COUNT_BITS", crate::bvh::LEAF_COUNT_BITS),
        ("BVH_LINK_LEAF", crate::bvh::LINK_LEAF),
        ("BVH_LINK_LAST", crate::bvh::LINK_LAST),
        ("BVH_LINK_END", crate::bvh::LINK_END),
        ("TEXELS_SRGB8", crate::scene::TEXELS_SRGB8),
        ("TEXELS_F32", crate::scene::TEXELS_F32),
        ("SHADE_OWN_ROW", SHADE_OWN_ROW),
        ("SHADE_FUZZY", SHADE_FUZZY),
        ("SHADE_POINTS", SHADE_POINTS),
        ("WEIGHTS_PLAIN_MEAN", WEIGHTS_PLAIN_MEAN),
        ("WEIGHTS_INVERSE_DISTANCE", WEIGHTS_INVERSE_DISTANCE),
        ("METRIC_EQ7", METRIC_EQ7),
        ("METRIC_WARD", METRIC_WARD),
        ("REPRESENTATIVE_NEAREST", REPRESENTATIVE_NEAREST),
        ("REPRESENTATIVE_MIN_ERROR", REPRESENTATIVE_MIN_ERROR),
        ("EXACT_DISK", vplgi_types::pod::EXACT_DISK),
        ("BSDF_DIFFUSE", vplgi_types::pod::BSDF_DIFFUSE),
        ("BSDF_MIRROR", vplgi_types::pod::BSDF_MIRROR),
        ("BSDF_ROUGH_CONDUCTOR", vplgi_types::pod::BSDF_ROUGH_CONDUCTOR),
        ("BSDF_DIELECTRIC", vplgi_types::pod::BSDF_DIELECTRIC),
        ("BSDF_THIN_DIELECTRIC", vplgi_types::pod::BSDF_THIN_DIELECTRIC),
        ("BSDF_BLEND", vplgi_types::pod::BSDF_BLEND),
        ("EXACT_POLYGON", vplgi_types::pod::EXACT_POLYGON),
        ("POLYGON_SIDES", vplgi_shared::polygon::SIDES as u32),
        ("REDUCE_ITEMS", REDUCE_ITEMS),
        ("VISIBILITY_ROW_LANES", VISIBILITY_ROW_LANES),
        ("CROWDED_CENTROIDS", vplgi_types::clustering::CROWDED_CENTROIDS),
        ("LIGHT_SHAPE_POINT", vplgi_types::LightShape::Point.code()),
        ("LIGHT_SHAPE_DISK", vplgi_types::LightShape::Disk.code()),
        ("LIGHT_SHAPE_DISK_EXACT", vplgi_types::LightShape::DiskExact.code()),
        ("LIGHT_SHAPE_POLYGON", vplgi_types::LightShape::Polygon.code()),
        ("RSM_AREA", vplgi_shared::rsm::RSM_AREA),
        ("RSM_POINT", vplgi_shared::rsm::RSM_POINT),
        ("RSM_SPOT", vplgi_shared::rsm::RSM_SPOT),
        ("RSM_DIRECTIONAL", vplgi_shared::rsm::RSM_DIRECTIONAL),
        ("RSM_NEIGHBOURHOOD", vplgi_shared::rsm::NEIGHBOURHOOD as u32),
        ("MAX_CAUSTIC_K", vplgi_types::params::MAX_CAUSTIC_K),
        ("CAUSTIC_VISITS", vplgi_types::params::CAUSTIC_VISITS),
        ("PHOTON_STACK", vplgi_shared::photon_tree::STACK as u32),
        ("GATHER_VISITS", vplgi_types::params::GATHER_VISITS),
        ("SH_COEFFICIENTS", vplgi_types::params::SH_COEFFICIENTS as u32),
        ("GLOSSY_DIRECTIONS", vplgi_types::params::GLOSSY_DIRECTIONS),
        ("CUT_ABOVE", vplgi_types::pod::CUT_ABOVE),
    ];
    let f = vec![
        ("POLYGON_CUT_TOLERANCE", vplgi_shared::polygon::CUT_TOLERANCE),
        ("DISK_MIN_TILT", vplgi_shared::disk::MIN_TILT),
        ("DISK_MIN_OFF_AXIS", vplgi_shared::disk::MIN_OFF_AXIS),
        ("PI", std::f32::consts::PI),
        ("FIX_ONE", vplgi_types::clustering::FIX_ONE),
        ("ERROR_ONE", vplgi_shared::seeding::ERROR_ONE),
        ("MAX_SURVIVAL", vplgi_types::params::MAX_SURVIVAL),
        ("SEGMENT_TNEAR", vplgi_types::params::SEGMENT_TNEAR),
        ("CRACK_ULPS", crate::bvh::CRACK_ULPS),
        ("SEGMENT_TFAR", vplgi_types::params::SEGMENT_TFAR),
        ("FACING_COS", vplgi_types::params::FACING_COS),
        ("CAUSTIC_NORMAL_COS", vplgi_types::params::CAUSTIC_NORMAL_COS),
        ("CUT_CENTRE_SKEW", vplgi_types::params::CUT_CENTRE_SKEW),
        ("GATHER_FALLBACK_REACH", vplgi_types::params::GATHER_FALLBACK_REACH),
        ("SH_L0", vplgi_shared::sh::SH_L0),
        ("SH_L1", vplgi_shared::sh::SH_L1),
        ("SH_L2_XY", vplgi_shared::sh::SH_L2_XY),
        ("SH_L2_ZZ", vplgi_shared::sh::SH_L2_ZZ),
        ("SH_L2_XX", vplgi_shared::sh::SH_L2_XX),
        ("SH_L3_XXY", vplgi_shared::sh::SH_L3_XXY),
        ("SH_L3_XYZ", vplgi_shared::sh::SH_L3_XYZ),
        ("SH_L3_YZZ", vplgi_shared::sh::SH_L3_YZZ),
        ("SH_L3_ZZZ", vplgi_shared::sh::SH_L3_ZZZ),
        ("SH_L3_ZXX", vplgi_shared::sh::SH_L3_ZXX),
        ("MIN_INTERPOLATION_ERROR", vplgi_types::interpolation::MIN_ERROR),
        ("ANY_ORIENTATION", vplgi_types::light_groups::ANY_ORIENTATION),
        ("PUNCTUAL_POINT", vplgi_types::device::PUNCTUAL_POINT),
        ("PUNCTUAL_SPOT", vplgi_types::device::PUNCTUAL_SPOT),
        ("PUNCTUAL_DIRECTIONAL", vplgi_types::device::PUNCTUAL_DIRECTIONAL),
    ];
    (u, f)
}

/// The constants WGSL shares with Rust, written from the Rust values (never typed twice): the
/// first lines of every composed module.
pub fn prelude() -> String {
    let (u, f) = shared_constants();
    let mut src =
        String::from("// Generated from the Rust values by vplgi_gpu::shader::prelude.\n");
    for (name, v) in u {
        src.push_str(&format!("const {name}: u32 = {v}u;\n"));
    }
    for (name, v) in f {
        // `{:?}` is the shortest decimal that reads back as the same f32, and always has a
        // fraction or an exponent, so WGSL parses a float.
        src.push_str(&format!("const {name}: f32 = {v:?};\n"));
    }
    src
}

/// The bindings of group 0 that entry point `entry` of stage `name` reads or writes, by naga's
/// analysis of the composed module: what wgpu derives the entry point's layout from. The sources
/// are compiled in, so a failure here is a defect of vplgi (the naga validation test names it).
pub fn used_bindings(name: &str, entry: &str) -> Vec<u32> {
    let src = compose(name);
    let (module, info) = validate(&src).unwrap_or_else(|e| panic!("{name}: {e}"));
    let index = module
        .entry_points
        .iter()
        .position(|e| e.name == entry)
        .unwrap_or_else(|| panic!("{name} has no entry point {entry}"));
    let uses = info.get_entry_point(index);
    module
        .global_variables
        .iter()
        .filter_map(|(h, v)| {
            v.binding.as_ref().filter(|b| b.group == 0 && !uses[h].is_empty()).map(|b| b.binding)
        })
        .collect()
}

/// The composed source of stage `name` (a file name from [`STAGES`]): the prelude, its common
/// files, then the stage file, each from the directory given to [`use_sources_from`] if it held
/// that file.
pub fn compose(name: &str) -> String {
    match REPLACED.get() {
        Some(map) => compose_from(name, map),
        None => compose_from(name, &BTreeMap::new()),
    }
}

fn compose_from(name: &str, replaced: &BTreeMap<&'static str, String>) -> String {
    let (_, stage, includes) = STAGES
        .iter()
        .find(|(n, _, _)| *n == name)
        .unwrap_or_else(|| panic!("unknown stage shader {name}"));
    let text_of = |n: &str, builtin: &'static str| replaced.get(n).map_or(builtin, String::as_str);
    let mut src = prelude();
    for inc in includes.iter() {
        let builtin = COMMON
            .iter()
            .find(|(n, _)| n == inc)
            .map(|(_, t)| *t)
            .unwrap_or_else(|| panic!("unknown common shader {inc}"));
        src.push_str(&format!("// ---- {inc}\n{}\n", text_of(inc, builtin)));
    }
    src.push_str(&format!("// ---- {name}\n{}\n", text_of(name, stage)));
    src
}

/// A compute pipeline for `entry` of stage `name`, with the layout derived from the shader.
pub fn pipeline(device: &wgpu::Device, name: &str, entry: &str) -> wgpu::ComputePipeline {
    pipelines(device, name, &[entry]).remove(0)
}

/// What a ray pipeline is specialised for: overrides that fold branches away when a scene does
/// not need them. lavapipe runs both sides of every branch for all lanes of a SIMD group, so a
/// branch no scene in hand takes still costs its loads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneVariant {
    /// The BVH's nodes or triangles spill into their second binding (`BVH_PAGED`).
    pub bvh_paged: bool,
    /// Some material has a base-colour texture (`TEXTURED`).
    pub textured: bool,
}

impl SceneVariant {
    /// Every branch kept: for stages compiled once for any scene.
    pub const GENERAL: SceneVariant = SceneVariant { bvh_paged: true, textured: true };

    fn index(self) -> usize {
        self.bvh_paged as usize * 2 + self.textured as usize
    }
}

/// The pipeline of a stage entry that traverses the BVH, in variants per [`SceneVariant`]. The
/// BVH's nodes and triangles may each spill into a second binding (`bvh_node`/`bvh_tri` in
/// bvh.wgsl), but branching between the pages on every node costs lavapipe, which runs both sides
/// of a branch for every lane, a large share of its traversal throughput (`examples/bvh_choice.rs`
/// measures it), and almost every scene fits one page. A texture lookup at every surface hit,
/// even one no lane takes, costs an untextured scene's `trace_vpls` kernel the same way. So the
/// pipeline every scene starts with is compiled
/// with `BVH_PAGED = false` and `TEXTURED = false`, which fold those branches away, and the
/// other variants are compiled the first time a scene needs one.
pub struct RayPipeline {
    name: &'static str,
    entry: &'static str,
    variants: [std::sync::OnceLock<wgpu::ComputePipeline>; 4],
    /// The bindings of group 0 the entry point uses (its layout is derived from them).
    used: Vec<u32>,
}

impl RayPipeline {
    pub fn new(device: &wgpu::Device, name: &'static str, entry: &'static str) -> RayPipeline {
        let pipeline = RayPipeline {
            name,
            entry,
            variants: Default::default(),
            used: used_bindings(name, entry),
        };
        pipeline.variant(device, SceneVariant { bvh_paged: false, textured: false });
        pipeline
    }

    /// The arrays of `scene.wgsl` this entry point reads, bound from `scene`: a stage binds its
    /// own arrays and these.
    pub fn scene_bindings<'a>(
        &self,
        scene: &'a crate::scene::GpuScene,
    ) -> Vec<(u32, wgpu::BufferBinding<'a>)> {
        scene.bindings(&self.used)
    }

    /// The variant for `scene`.
    pub fn get(
        &self,
        device: &wgpu::Device,
        scene: &crate::scene::GpuScene,
    ) -> &wgpu::ComputePipeline {
        self.variant(device, SceneVariant { bvh_paged: scene.bvh_paged, textured: scene.textured })
    }

    fn variant(&self, device: &wgpu::Device, v: SceneVariant) -> &wgpu::ComputePipeline {
        self.variants[v.index()]
            .get_or_init(|| compile(device, self.name, &[self.entry], v, &[]).remove(0))
    }
}

/// The page-size overrides of the paged scene arrays a stage reads, from the device's limits,
/// and whether the BVH arrays may use their second pages.
fn page_constants(
    device: &wgpu::Device,
    name: &str,
    variant: SceneVariant,
) -> Vec<(&'static str, f64)> {
    let includes = STAGES.iter().find(|(n, _, _)| *n == name).map(|(_, _, i)| *i).unwrap_or(&[]);
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    let mut c = Vec::new();
    if includes.contains(&"common/bvh.wgsl") {
        c.push(("BVH_PAGED", flag(variant.bvh_paged)));
        c.push((
            "BVH_NODE_PAGE",
            page_len::<crate::bvh::BvhNode>(device).min(u32::MAX as u64) as f64,
        ));
        c.push((
            "BVH_TRI_PAGE",
            page_len::<crate::bvh::BvhTri>(device).min(u32::MAX as u64) as f64,
        ));
    }
    if includes.contains(&"common/surface.wgsl") {
        c.push((
            "SCENE_TRI_PAGE",
            page_len::<crate::scene::SceneTri>(device).min(u32::MAX as u64) as f64,
        ));
        c.push(("TEXEL_PAGE", page_len::<u32>(device).min(u32::MAX as u64) as f64));
        c.push(("TEXTURED", flag(variant.textured)));
    }
    c
}

/// One pipeline per entry point of stage `name`, compiled from one module. Each layout is
/// derived from the bindings its entry point uses.
pub fn pipelines(
    device: &wgpu::Device,
    name: &str,
    entries: &[&str],
) -> Vec<wgpu::ComputePipeline> {
    compile(device, name, entries, SceneVariant::GENERAL, &[])
}

/// The pipeline of `entry` of stage `name` with its own values of some of the module's overrides
/// (e.g. a loop's trip count, fixed so that the loop is unrolled), for an entry point that does
/// not traverse the BVH.
pub fn pipeline_with(
    device: &wgpu::Device,
    name: &str,
    entry: &str,
    overrides: &[(&'static str, f64)],
) -> wgpu::ComputePipeline {
    compile(device, name, &[entry], SceneVariant::GENERAL, overrides).remove(0)
}

fn compile(
    device: &wgpu::Device,
    name: &str,
    entries: &[&str],
    variant: SceneVariant,
    overrides: &[(&'static str, f64)],
) -> Vec<wgpu::ComputePipeline> {
    let desc = wgpu::ShaderModuleDescriptor {
        label: Some(name),
        source: wgpu::ShaderSource::Wgsl(compose(name).into()),
    };
    let module = match REPLACED.get() {
        // Sources from a user's directory (--shaders) are untrusted: every check stays on.
        Some(_) => device.create_shader_module(desc),
        // SAFETY: wgpu's only requirement for dropping its loop bounding is that no loop of these
        // modules runs forever, and every loop of vplgi's compiled-in kernels is bounded by its
        // inputs: counts and index ranges, binary searches that halve a range, ring searches up
        // to the grid's extent, and BVH traversal, whose node index only moves forward in
        // preorder (a child is the next node, a skip link points past the subtree) until
        // BVH_END. Bounds checks stay on. The bounding costs a 64-bit counter update and a
        // branch per iteration of every loop, in the hottest loops of every kernel.
        None => unsafe {
            device.create_shader_module_trusted(
                desc,
                wgpu::ShaderRuntimeChecks {
                    force_loop_bounding: false,
                    ..wgpu::ShaderRuntimeChecks::checked()
                },
            )
        },
    };
    let mut constants = page_constants(device, name, variant);
    constants.extend_from_slice(overrides);
    entries
        .iter()
        .map(|entry| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                cache: None,
            })
        })
        .collect()
}

/// The layout check of records shared with WGSL: a Rust record, the WGSL struct it is read as,
/// and the record's named fields, against naga's layout of the composed module.
#[cfg(test)]
pub(crate) mod layout {
    use super::compose;

    /// One row of the layout table: a Rust record, the WGSL struct it is read as, and the
    /// record's named fields (padding is covered by the size).
    pub(crate) struct Row {
        pub(crate) stage: &'static str,
        pub(crate) wgsl: &'static str,
        pub(crate) rust: &'static str,
        pub(crate) size: usize,
        pub(crate) fields: Vec<(&'static str, usize)>,
    }

    /// `[Type] "stage.wgsl" WgslName { field, ... }`: the row of a record whose fields have the
    /// same names on both sides.
    #[macro_export]
    macro_rules! layout_rows {
        ($([$ty:path] $stage:literal $wgsl:literal { $($field:ident),* $(,)? })*) => {
            vec![$($crate::shader::layout::Row {
                stage: $stage,
                wgsl: $wgsl,
                rust: stringify!($ty),
                size: std::mem::size_of::<$ty>(),
                fields: vec![$((stringify!($field), std::mem::offset_of!($ty, $field))),*],
            }),*]
        };
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
                    return (
                        *span,
                        members
                            .iter()
                            .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                            .collect(),
                    );
                }
            }
        }
        panic!("struct {name} not found in {stage}");
    }

    /// Every row has the size and field offsets naga lays out in WGSL.
    pub(crate) fn check(table: Vec<Row>) {
        for row in table {
            let (size, members) = wgsl_layout(row.stage, row.wgsl);
            assert_eq!(
                size as usize, row.size,
                "{} ({}): WGSL size {size}, Rust size {}",
                row.rust, row.stage, row.size
            );
            for (field, offset) in row.fields {
                let m = members.iter().find(|(n, _)| n == field).unwrap_or_else(|| {
                    panic!("{}.{field}: no such member of {} in {}", row.rust, row.wgsl, row.stage)
                });
                assert_eq!(
                    m.1 as usize, offset,
                    "{}.{field}: WGSL offset {}, Rust offset {offset}",
                    row.rust, m.1
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every stage, composed with the common files, parses and validates with naga: no GPU needed.
    #[test]
    fn every_wgsl_file_validates() {
        for (name, _, _) in STAGES {
            if let Err(e) = validate(&compose(name)) {
                panic!("{name}: {e}");
            }
        }
    }

    /// A directory of shader sources: its files are read by name, a broken one is refused with
    /// its name and naga's report (without touching the process's sources), an empty one too.
    #[test]
    fn sources_from_a_directory_are_checked_before_use() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let empty = compose_from("shade.wgsl", &BTreeMap::new());
        assert!(matches!(use_sources_from(dir.path()), Err(SourceError::Empty { .. })));
        std::fs::create_dir(dir.path().join("common")).expect("mkdir");
        let rng = COMMON.iter().find(|(n, _)| *n == "common/rng.wgsl").expect("rng.wgsl").1;
        std::fs::write(dir.path().join("common/rng.wgsl"), rng.replacen("fn ", "fn broken(", 1))
            .expect("write");
        match use_sources_from(dir.path()) {
            Err(SourceError::Invalid { file, stage, message }) => {
                assert_eq!(file, "common/rng.wgsl");
                assert!(!stage.is_empty() && !message.is_empty());
            }
            other => panic!("a broken common file was accepted: {other:?}"),
        }
        assert!(REPLACED.get().is_none(), "a refused directory must not replace the sources");
        let mut map = BTreeMap::new();
        map.insert("shade.wgsl", "// replaced".to_string());
        assert!(
            compose_from("shade.wgsl", &map).ends_with("// replaced\n")
                && !empty.ends_with("// replaced\n")
        );
    }

    /// `scene.wgsl` declares the scene's arrays at the bindings and under the names of
    /// `scene::SCENE_BINDINGS`, and every stage that includes it sees all of them.
    #[test]
    fn scene_declarations_match_the_binding_table() {
        use crate::scene::{FIRST_SCENE_BINDING, SCENE_BINDINGS};
        let with_scene: Vec<&str> = STAGES
            .iter()
            .filter(|(_, _, inc)| inc.contains(&"common/scene.wgsl"))
            .map(|(n, _, _)| *n)
            .collect();
        assert_eq!(with_scene.len(), 8, "the ray-tracing stages: {with_scene:?}");
        for stage in with_scene {
            let module = naga::front::wgsl::parse_str(&compose(stage)).expect("parses");
            let mut seen: Vec<(u32, String)> = module
                .global_variables
                .iter()
                .filter_map(|(_, v)| {
                    v.binding
                        .as_ref()
                        .filter(|b| b.binding >= FIRST_SCENE_BINDING)
                        .map(|b| (b.binding, v.name.clone().unwrap_or_default()))
                })
                .collect();
            seen.sort();
            let table: Vec<(u32, String)> = (FIRST_SCENE_BINDING..)
                .zip(SCENE_BINDINGS)
                .map(|(n, (name, _))| (n, name.to_string()))
                .collect();
            assert_eq!(seen, table, "{stage}");
            // A stage's own bindings stay below the scene's.
            assert!(
                module
                    .global_variables
                    .iter()
                    .all(|(_, v)| v.binding.as_ref().is_none_or(|b| b.group == 0)),
                "{stage}"
            );
        }
        // Each pipeline binds what its entry point uses: visibility reads the BVH, not the texels.
        let used = used_bindings("visibility.wgsl", "main");
        assert!(
            used.contains(&FIRST_SCENE_BINDING) && !used.contains(&(FIRST_SCENE_BINDING + 10)),
            "{used:?}"
        );
    }

    /// Every constant of the prelude reads back, in naga, as the bits of its Rust value.
    #[test]
    fn prelude_constants_are_the_rust_values() {
        let module = naga::front::wgsl::parse_str(&prelude()).expect("the prelude parses");
        let (u, f) = shared_constants();
        assert_eq!(module.constants.len(), u.len() + f.len());
        for (_, c) in module.constants.iter() {
            let name = c.name.as_deref().unwrap_or_default();
            let naga::Expression::Literal(lit) = module.global_expressions[c.init] else {
                panic!("{name} is not a literal")
            };
            match lit {
                naga::Literal::U32(v) => {
                    assert_eq!(Some(v), u.iter().find(|x| x.0 == name).map(|x| x.1), "{name}")
                }
                naga::Literal::F32(v) => assert_eq!(
                    Some(v.to_bits()),
                    f.iter().find(|x| x.0 == name).map(|x| x.1.to_bits()),
                    "{name}"
                ),
                other => panic!("{name}: unexpected literal {other:?}"),
            }
        }
    }

    /// Every record that crosses between host and device, and the glue's parameters, has the
    /// same size and field offsets in Rust as naga lays out in WGSL. A stage's own parameters
    /// are checked in its module.
    #[test]
    fn shared_structs_match_their_wgsl_layout() {
        use crate::bvh::BvhTri;
        use crate::lights::{Emitter, LightGroup, Punctual};
        use crate::scene::{GpuMaterial, SceneTri, TextureInfo};
        use vplgi_types::{CutBound, CutNode, Endpoint, PhotonNode, ShadingPoint, Vpl, VplLight};
        let table = crate::layout_rows! {
            [ShadingPoint] "shading_points.wgsl" "ShadingPoint" { position, pixel, normal, triangle, albedo, specular, emitted, material, view }
            [Vpl] "trace_vpls.wgsl" "Vpl" { position, path, normal, bounce, flux, specular, incoming, material }
            [Endpoint] "visibility.wgsl" "Endpoint" { position, normal }
            [PhotonNode] "caustics.wgsl" "PhotonNode" { lo, first, hi, count }
            [CutNode] "final_gather.wgsl" "CutNode" { position, radius, normal, irradiance }
            [CutBound] "final_gather.wgsl" "CutBound" { lo, slot, hi }
            [VplLight] "shade.wgsl" "VplLight" { position, normal, flux, incoming }
            [SceneTri] "shading_points.wgsl" "SceneTri" { ng, n0, n1, n2, uv01, uv2 }
            [GpuMaterial] "shading_points.wgsl" "Material" { base_color, emission, bsdf }
            [TextureInfo] "shading_points.wgsl" "TextureInfo" { offset, width, height, format }
            [BvhTri] "visibility.wgsl" "BvhTri" { v0, v1, v2 }
            [Emitter] "shade.wgsl" "Emitter" { v0, e1, e2, normal, radiance }
            [LightGroup] "shade.wgsl" "LightGroup" { sphere, cone, power, range }
            [Punctual] "shade.wgsl" "Punctual" { position, direction, intensity }
            [crate::backend::GlueParams] "frame.wgsl" "Params" { n, k, first, end, hit_first, hit_count, phase, max_bounce, shape }
            [crate::rng::Params] "rng_streams.wgsl" "Params" { seed, stream, first_index, count, draws }
            [vplgi_shared::rsm::RsmLight] "rsm_vpls.wgsl" "RsmLight" { origin, kind, e1, size, e2, first, axis, cos_inner, power, cos_outer }
            [vplgi_shared::rsm::RsmCentre] "rsm_cluster.wgsl" "ClusterState" { centre, texel_x, normal, texel_y, chroma, map }
        };
        crate::shader::layout::check(table);
    }
}
