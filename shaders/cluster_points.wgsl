// Cluster pass: work over a point set on its own: gathering points by index (seeds, the
// downsampled set, the representatives' rows), the points' bounding box, and the totals of the
// search outcomes.

@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(2) var<storage, read> index: array<u32>;
@group(0) @binding(3) var<storage, read_write> gathered: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> outcome_totals: array<atomic<u32>>;
@group(0) @binding(9) var<storage, read_write> box_keys: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read> outcome: array<u32>;

// gathered[t] = points[index[t]] for the indices that fall in the bound window of points
// (params.first .. + params.window); `index` and `gathered` are windows of params.n items.
// The host runs every pair of output and point windows (seeds, the downsampled set,
// representatives' rows).
@compute @workgroup_size(64)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= params.n) {
        return;
    }
    let p = index[t];
    if (p >= params.first && p - params.first < params.window) {
        gathered[t] = points[p - params.first];
    }
}

// Bounds of the points as order-preserving u32 keys: box_keys[0..3] = min, [3..6] = max.
fn order_key(f: f32) -> u32 {
    let u = bitcast<u32>(f);
    return select(u | 0x80000000u, ~u, (u & 0x80000000u) != 0u);
}

@compute @workgroup_size(64)
fn bounds(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let p = points[i].position.xyz;
    for (var a = 0u; a < 3u; a = a + 1u) {
        atomicMin(&box_keys[a], order_key(p[a]));
        atomicMax(&box_keys[3u + a], order_key(p[a]));
    }
}

// How the searches ended: outcome_totals[0] neighbourhood, [1] widened, [2] incompatible.
@compute @workgroup_size(64)
fn outcome_counts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    atomicAdd(&outcome_totals[outcome[i]], 1u);
}
