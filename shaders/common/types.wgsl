// Records shared with Rust (vplgi-types/src/pod.rs and vplgi-gpu/src/scene.rs). Each vec3 is
// followed by a 4-byte scalar, so WGSL and #[repr(C)] Rust agree on offsets (checked by a test).

struct ShadingPoint {
    position: vec3<f32>,
    pixel: u32,
    normal: vec3<f32>,
    triangle: u32,
    albedo: vec3<f32>,
    specular: u32,       // mirrors and glass passed on the way (shading_points.wgsl)
    emitted: vec3<f32>,
    material: u32,       // the hit's material index
    view: vec3<f32>,     // toward where the ray that found it came from
    pad2: u32,
}

struct Vpl {
    position: vec3<f32>,
    path: u32,
    normal: vec3<f32>,
    bounce: u32,
    flux: vec3<f32>,
    specular: u32,   // mirrors and glass passed since the light (trace_vpls)
    incoming: vec3<f32>, // toward where the light came from
    material: u32,       // whose BSDF the VPL emits through
}

// A node of a photon map's balanced kd-tree (vplgi_shared::photon_tree): the box of photons
// first .. first + count; children 2i + 1 and 2i + 2.
struct PhotonNode {
    lo: vec3<f32>,
    first: u32,
    hi: vec3<f32>,
    count: u32,
}

// A node of the illumination cut (vplgi_types::CutNode): representative position and normal,
// radius r_p, and an irradiance (Eq. 3's estimate, or the density estimate in the cut).
struct CutNode {
    position: vec3<f32>,
    radius: f32,
    normal: vec3<f32>,
    pad0: u32,
    irradiance: vec3<f32>,
    pad1: u32,
}

// A photon-tree node as final gathering walks it (vplgi_types::CutBound): the box around the
// kernels of the cut nodes below, and the cut slot or CUT_ABOVE.
struct CutBound {
    lo: vec3<f32>,
    slot: u32,
    hi: vec3<f32>,
    pad: u32,
}

// A VPL, or a VPL cluster at its representative with its members' summed flux, as a light.
struct VplLight {
    position: vec4<f32>,
    normal: vec4<f32>,
    flux: vec4<f32>,
    incoming: vec4<f32>, // w: bitcast of the material it emits through
}
// Its exact form factor, VplLight::exact, is in the normal's w (EXACT_DISK, EXACT_POLYGON); a
// polygon's outline has POLYGON_SIDES vertices.

// disk::perpendicular
fn disk_perpendicular(normal: vec3<f32>) -> vec3<f32> {
    var other = vec3<f32>(0.0, 1.0, 0.0);
    if (abs(normal.x) < 0.9) {
        other = vec3<f32>(1.0, 0.0, 0.0);
    }
    return normalize(cross(normal, other));
}

// One light's reflective shadow map (vplgi_types::rsm::RsmLight).
struct RsmLight {
    origin: vec3<f32>,
    kind: u32,
    e1: vec3<f32>,
    size: u32,
    e2: vec3<f32>,
    first: u32,
    axis: vec3<f32>,
    cos_inner: f32,
    power: vec3<f32>,
    cos_outer: f32,
}

// A surface point at one end of a shadow ray.
struct Endpoint {
    position: vec4<f32>,
    normal: vec4<f32>,
}

// Per-triangle shading data, indexed by the scene's triangle index.
struct SceneTri {
    ng: vec4<f32>,   // xyz = unit front normal, w = bitcast<f32>(material index)
    n0: vec4<f32>,   // vertex normals
    n1: vec4<f32>,
    n2: vec4<f32>,
    uv01: vec4<f32>, // uv of vertex 0 (xy) and 1 (zw)
    uv2: vec4<f32>,  // uv of vertex 2 (xy)
}

// One surface's BSDF (vplgi_types::BsdfRecord; common/bsdf.wgsl evaluates it).
struct BsdfRecord {
    reflectance: vec3<f32>,
    kind: u32,
    alpha: f32,
    eta: f32,
    metallic: f32,
    pad: u32,
}

struct Material {
    base_color: vec4<f32>, // w = bitcast<f32>(texture index), MISS when untextured
    emission: vec4<f32>,
    bsdf: BsdfRecord,      // reflectance 0: the hit's colour goes there (surface_at)
}

// Where a texture's texels start in the texel array, and its size.
struct TextureInfo {
    offset: u32,          // first texel word (texel_word in surface.wgsl)
    width: u32,
    height: u32,
    format: u32,          // 0: one word of 8-bit sRGB codes per texel, 1: three f32 words
}

// Light records (vplgi_types::device::{Emitter, Punctual}), read through lights.wgsl.
struct Emitter {
    v0: vec4<f32>,        // w = area
    e1: vec4<f32>,
    e2: vec4<f32>,
    normal: vec4<f32>,    // unit front normal
    radiance: vec4<f32>,
}

// vplgi_types::device::LightGroup
struct LightGroup {
    sphere: vec4<f32>,    // centre, radius
    cone: vec4<f32>,      // axis, cos of the half-angle (ANY_ORIENTATION: none)
    power: vec4<f32>,     // power, realised probability in area_table, area_table's CDF before it
    range: vec4<u32>,     // first emitter, count
}

struct Punctual {
    position: vec4<f32>,  // w = 0 point, 1 spot, 2 directional (vplgi_types::device::Punctual)
    direction: vec4<f32>, // w = cos_inner
    intensity: vec4<f32>, // w = cos_outer
}

// The invocation's item index. Dispatches of more workgroups than one dimension allows are split
// over y by vplgi_gpu::buffers::dispatch (64 invocations per workgroup everywhere).
fn thread_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

// G = cos cos / d^2 between surface points p and x (normals np, nx), 0 where either faces away
// (vplgi-cpu shade::geometry_term without its clamp; shade clamps it, bias_points compares it
// with the clamp's bound).
fn unclamped_geometry_term(p: vec3<f32>, np: vec3<f32>, x: vec3<f32>, nx: vec3<f32>) -> f32 {
    let d = x - p;
    let d2 = dot(d, d);
    if (d2 <= 0.0) {
        return 0.0;
    }
    let inv_d = 1.0 / sqrt(d2);
    let cos_p = dot(np, d) * inv_d;
    let cos_x = -dot(nx, d) * inv_d;
    if (cos_p <= 0.0 || cos_x <= 0.0) {
        return 0.0;
    }
    return cos_p * cos_x / d2;
}

// Pushes p off its surface (normal n) towards the side where `toward` lies
// (vplgi-cpu CpuScene::offset_toward).
fn offset_toward(p: vec3<f32>, n: vec3<f32>, toward: vec3<f32>, eps: f32) -> vec3<f32> {
    var side = -1.0;
    if (dot(n, toward - p) >= 0.0) {
        side = 1.0;
    }
    return p + n * (side * eps);
}
