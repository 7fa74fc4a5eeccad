// include: common/types.wgsl common/rng.wgsl common/bvh.wgsl common/surface.wgsl common/scene.wgsl common/sampling.wgsl common/bsdf.wgsl common/specular.wgsl
// Stage 2, shading_points: one primary ray per camera sample (vplgi-cpu/src/shading_points.rs).
// Sample i belongs to pixel i / spp; with spp = 1 it goes through the pixel centre, otherwise it
// is jittered with the stream (seed, STREAM_CAMERA, i), and its emission is the pixel's,
// estimated from EMISSION_STRATA^2 stratified rays drawn next from that stream. Every ray follows
// mirrors and glass (camera_path) with the stream (seed, STREAM_SPECULAR, i).

struct Params {
    cam_pos: vec4<f32>,      // xyz
    cam_forward: vec4<f32>,  // xyz
    cam_up: vec4<f32>,       // xyz
    cam_right: vec4<f32>,    // xyz = normalize(cross(forward, up)), w = tan(yfov / 2)
    width: u32,
    height: u32,
    spp: u32,
    seed: u32,
    first: u32,              // first sample of this dispatch (chunking)
    count: u32,              // samples in this dispatch
    specular_depth: u32,     // specular vertices a ray may pass
    eps: f32,                // ray offset (Scene::ray_epsilon)
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(7) var<storage, read_write> out: array<ShadingPoint>;

// vplgi_scene::Camera::ray_direction through film position (sx, sy).
fn camera_ray(sx: f32, sy: f32) -> vec3<f32> {
    let aspect = f32(params.width) / f32(params.height);
    let tan_half = params.cam_right.w;
    let px = (2.0 * sx / f32(params.width) - 1.0) * tan_half * aspect;
    let py = (1.0 - 2.0 * sy / f32(params.height)) * tan_half;
    return normalize(params.cam_forward.xyz + params.cam_right.xyz * px + params.cam_up.xyz * py);
}

// Where a camera ray ends up after the mirrors and glass it meets (camera_path on the CPU).
struct CameraPath {
    surf: Surface,
    triangle: u32,          // NO_HIT: the chain left the scene
    throughput: vec3<f32>,  // product of the specular vertices' sample weights
    emitted: vec3<f32>,     // emission seen along the chain, the last surface's included
    specular: u32,          // specular vertices passed
    view: vec3<f32>,        // from the last surface back along the ray that reached it
}

// Follows origin + t dir through at most params.specular_depth specular vertices, reflecting or
// refracting as the surface's BSDF samples with one number of `chain` each, to the first other
// surface (or the surface after the last allowed vertex, whatever it is).
fn camera_path(origin_in: vec3<f32>, dir_in: vec3<f32>, chain: ptr<function, Rng>) -> CameraPath {
    let inf = bitcast<f32>(0x7f800000u);
    var path: CameraPath;
    path.triangle = NO_HIT;
    path.throughput = vec3<f32>(1.0);
    path.emitted = vec3<f32>(0.0);
    path.specular = 0u;
    var origin = origin_in;
    var dir = dir_in;
    loop {
        let hit = bvh_trace(origin, dir, 0.0, inf, false);
        if (hit.triangle == NO_HIT) {
            break;
        }
        let surf = surface_at(hit, dir);
        path.emitted = path.emitted + path.throughput * surf.emitted;
        if (path.specular == params.specular_depth || !bsdf_is_specular(surf.bsdf)) {
            path.surf = surf;
            path.triangle = hit.triangle;
            path.view = -dir;
            break;
        }
        let s = scatter_specular(surf, dir, rng_next_f32(chain), true);
        if (s.valid == 0u) {
            break;
        }
        path.throughput = path.throughput * s.weight;
        path.specular = path.specular + 1u;
        dir = s.wo;
        origin = offset_toward(surf.position, surf.ng, surf.position + dir, params.eps);
    }
    return path;
}

// The emission seen through the pixel whose top-left corner is (x, y): the mean over one ray
// jittered in each cell of an EMISSION_STRATA^2 grid over the pixel (pixel_emission on the CPU).
fn pixel_emission(x: f32, y: f32, rng: ptr<function, Rng>, chain: ptr<function, Rng>) -> vec3<f32> {
    let cell = 1.0 / f32(EMISSION_STRATA);
    var sum = vec3<f32>(0.0);
    for (var j = 0u; j < EMISSION_STRATA; j = j + 1u) {
        for (var i = 0u; i < EMISSION_STRATA; i = i + 1u) {
            let sx = x + (f32(i) + rng_next_f32(rng)) * cell;
            let sy = y + (f32(j) + rng_next_f32(rng)) * cell;
            sum = sum + camera_path(params.cam_pos.xyz, camera_ray(sx, sy), chain).emitted;
        }
    }
    return sum / f32(EMISSION_STRATA * EMISSION_STRATA);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = thread_index(gid, groups);
    if (local >= params.count) {
        return;
    }
    let i = params.first + local;
    let pixel = i / params.spp;
    let x = f32(pixel % params.width);
    let y = f32(pixel / params.width);
    var sx = x + 0.5;
    var sy = y + 0.5;
    var rng = rng_new(params.seed, STREAM_CAMERA, i);
    var chain = rng_new(params.seed, STREAM_SPECULAR, i);
    if (params.spp != 1u) {
        sx = x + rng_next_f32(&rng);
        sy = y + rng_next_f32(&rng);
    }
    let path = camera_path(params.cam_pos.xyz, camera_ray(sx, sy), &chain);
    var sp: ShadingPoint;
    sp.pixel = pixel;
    sp.triangle = MISS;
    sp.specular = path.specular;
    sp.emitted = path.emitted;
    if (path.triangle != NO_HIT) {
        sp.position = path.surf.position;
        sp.normal = path.surf.ns;
        sp.triangle = path.triangle;
        sp.albedo = path.throughput * path.surf.albedo;
        sp.view = path.view;
        sp.material = path.surf.material;
    }
    // A miss carries its pixel's emission too, as on the CPU.
    if (params.spp != 1u) {
        sp.emitted = pixel_emission(x, y, &rng, &chain);
    }
    out[local] = sp;
}
