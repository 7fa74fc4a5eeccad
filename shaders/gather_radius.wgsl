// include: common/types.wgsl common/rng.wgsl common/bvh.wgsl common/sampling.wgsl common/scene.wgsl
// Stage gather_radius (vplgi-cpu/src/gather_radius.rs): per sample point, 1 / R_j, the mean over
// its gather rays of 1 / t for hits beyond the offset eps (an escaped ray adds 0), R_j being the harmonic mean distance of Wang
// et al.'s interpolation weight. Ray r draws two numbers from stream (seed, STREAM_GATHER, j) at
// counter 2r. A dispatch traces rays ray_first .. ray_end of every point and continues the sums
// in `sums` (lavapipe ends an invocation's loops, traversal included, after 65,535 iterations);
// the last dispatch divides by the ray count.

struct Params {
    count: u32,
    seed: u32,
    rays: u32,        // rays per point in all
    ray_first: u32,
    ray_end: u32,
    eps: f32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(6) var<storage, read> points: array<Endpoint>;
@group(0) @binding(7) var<storage, read_write> sums: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.count) {
        return;
    }
    let e = points[j];
    let n = e.normal.xyz;
    var rng = rng_new(params.seed, STREAM_GATHER, j);
    rng.counter = 2u * params.ray_first;
    // Pushed off along the normal, as on the CPU: not the point's own surface at t ~ 0.
    let origin = e.position.xyz + n * params.eps;
    let inf = bitcast<f32>(0x7f800000u);
    var sum = select(0.0, sums[j], params.ray_first > 0u);
    for (var r = params.ray_first; r < params.ray_end; r = r + 1u) {
        let u1 = rng_next_f32(&rng);
        let u2 = rng_next_f32(&rng);
        let dir = cosine_hemisphere(n, u1, u2);
        // Hits beyond the offset only (gather_radius.rs: a point on a corner edge starts on the
        // other surface's plane).
        let hit = bvh_trace(origin, dir, params.eps, inf, false);
        if (hit.triangle != NO_HIT) {
            sum = sum + 1.0 / hit.t;
        }
    }
    // interpolation::inverse_radius once every ray is in.
    if (params.ray_end == params.rays) {
        sum = sum / f32(max(params.rays, 1u));
    }
    sums[j] = sum;
}
