// Stage 2, shading_points: one primary ray per camera sample (vplgi-cpu/src/shading_points.rs).
// Sample i belongs to pixel i / spp; with spp = 1 it goes through the pixel centre, otherwise it
// is jittered with the stream (seed, STREAM_CAMERA, i).

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
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(7) var<storage, read_write> out: array<ShadingPoint>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = thread_index(gid, groups);
    if (local >= params.count) {
        return;
    }
    let i = params.first + local;
    let pixel = i / params.spp;
    var sx = f32(pixel % params.width) + 0.5;
    var sy = f32(pixel / params.width) + 0.5;
    if (params.spp != 1u) {
        var rng = rng_new(params.seed, STREAM_CAMERA, i);
        sx = f32(pixel % params.width) + rng_next_f32(&rng);
        sy = f32(pixel / params.width) + rng_next_f32(&rng);
    }
    // vplgi_scene::Camera::ray_direction
    let aspect = f32(params.width) / f32(params.height);
    let tan_half = params.cam_right.w;
    let px = (2.0 * sx / f32(params.width) - 1.0) * tan_half * aspect;
    let py = (1.0 - 2.0 * sy / f32(params.height)) * tan_half;
    let dir = normalize(params.cam_forward.xyz + params.cam_right.xyz * px + params.cam_up.xyz * py);

    let inf = bitcast<f32>(0x7f800000u);
    let hit = bvh_trace(params.cam_pos.xyz, dir, 0.0, inf, false);
    var sp: ShadingPoint;
    sp.pixel = pixel;
    sp.triangle = MISS;
    if (hit.triangle != NO_HIT) {
        let surf = surface_at(hit, dir);
        sp.position = surf.position;
        sp.normal = surf.ns;
        sp.triangle = hit.triangle;
        sp.albedo = surf.albedo;
        sp.emitted = surf.emitted;
    }
    out[local] = sp;
}
