// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
// Cluster pass: the centroid update of Alg. 1 with FixedPoint sums (vplgi_types::clustering):
// 64-bit sums as (lo, hi) u32 pairs with a carry, so the result does not depend on thread order.

@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(3) var<storage, read_write> centroids: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> counts: array<atomic<u32>>;   // members per cluster
@group(0) @binding(7) var<storage, read> labels: array<u32>;
@group(0) @binding(9) var<storage, read_write> sums: array<atomic<u32>>;     // 12 words per cluster

// ---- centroid update (FixedPoint): 64-bit sums as (lo, hi) u32 pairs with a carry.

fn add64(slot: u32, v: u32) {
    let old = atomicAdd(&sums[slot], v);
    if (old > 0xffffffffu - v) {
        atomicAdd(&sums[slot + 1u], 1u);
    }
}

@compute @workgroup_size(64)
fn accumulate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    if (l == MISS) {
        return;
    }
    let pt = points[i];
    let qu = fix_position(pt.position.xyz, params.fix_min.xyz, params.fix_ext.xyz);
    let mu = fix_normal(pt.normal.xyz);
    let base = l * 12u;
    add64(base + 0u, qu.x);
    add64(base + 2u, qu.y);
    add64(base + 4u, qu.z);
    add64(base + 6u, mu.x);
    add64(base + 8u, mu.y);
    add64(base + 10u, mu.z);
    atomicAdd(&counts[l], 1u);
}

fn sum_mean(slot: u32, count: u32) -> f32 {
    return mean64(atomicLoad(&sums[slot]), atomicLoad(&sums[slot + 1u]), count);
}

@compute @workgroup_size(64)
fn finalize(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    let count = atomicLoad(&counts[k]);
    if (count == 0u) {
        return;
    }
    let base = k * 12u;
    let m = vec3<f32>(sum_mean(base, count), sum_mean(base + 2u, count), sum_mean(base + 4u, count));
    let mn = vec3<f32>(sum_mean(base + 6u, count), sum_mean(base + 8u, count), sum_mean(base + 10u, count));
    centroids[k].position = vec4<f32>(fix_mean_position(m, params.fix_min.xyz, params.fix_ext.xyz), 0.0);
    // A cluster whose members' normals cancel keeps its normal (FixedPoint::mean gives None).
    let nrm = fix_mean_normal(mn);
    if (any(nrm != vec3<f32>(0.0))) {
        centroids[k].normal = vec4<f32>(nrm, 0.0);
    }
}
