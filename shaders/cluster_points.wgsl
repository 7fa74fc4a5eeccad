// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
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

// The bounds and the outcome totals are reductions: each invocation folds REDUCE_ITEMS
// consecutive points in registers and adds its result to the global keys with one atomic each.
// Atomics cost lavapipe a locked instruction per lane, so one invocation per point (6 atomics
// each) would spend its time in them; staging them in workgroup atomics first saves little.
@compute @workgroup_size(64)
fn bounds(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let first = thread_index(gid, groups) * REDUCE_ITEMS;
    let end = min(first + REDUCE_ITEMS, params.n);
    if (first >= end) {
        return;
    }
    var lo = vec3<u32>(0xffffffffu);
    var hi = vec3<u32>(0u);
    for (var i = first; i < end; i = i + 1u) {
        let p = points[i].position.xyz;
        let key = vec3<u32>(order_key(p.x), order_key(p.y), order_key(p.z));
        lo = min(lo, key);
        hi = max(hi, key);
    }
    for (var a = 0u; a < 3u; a = a + 1u) {
        atomicMin(&box_keys[a], lo[a]);
        atomicMax(&box_keys[3u + a], hi[a]);
    }
}

// How the searches ended: outcome_totals[0] neighbourhood, [1] widened, [2] incompatible.
@compute @workgroup_size(64)
fn outcome_counts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let first = thread_index(gid, groups) * REDUCE_ITEMS;
    let end = min(first + REDUCE_ITEMS, params.n);
    if (first >= end) {
        return;
    }
    var totals = vec3<u32>(0u);
    for (var i = first; i < end; i = i + 1u) {
        let o = outcome[i];
        totals = totals + vec3<u32>(u32(o == 0u), u32(o == 1u), u32(o == 2u));
    }
    for (var a = 0u; a < 3u; a = a + 1u) {
        if (totals[a] != 0u) {
            atomicAdd(&outcome_totals[a], totals[a]);
        }
    }
}
