// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
// Cluster pass: each cluster's representative, the member (by first label) nearest its centroid,
// or of smallest Eq. 2 error to it (Representative::key of vplgi-types/src/clustering.rs).

@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(3) var<storage, read> centroids: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> best_d2: array<atomic<u32>>;          // per cluster: the smallest key, as f32 bits
@group(0) @binding(7) var<storage, read> labels: array<u32>;
@group(0) @binding(9) var<storage, read_write> representatives: array<atomic<u32>>;  // per cluster: a point index

// ---- representatives: per cluster the member (by first label) of smallest key, ties to the
// lower index: first the minimum key (as ordered bits of a non-negative float), then the lowest
// index among the points with that key.

fn rep_key(pt: Endpoint, c: Endpoint) -> f32 {
    let d = dist2(pt.position.xyz, c.position.xyz);
    if (params.representative == REPRESENTATIVE_MIN_ERROR) {
        return ward_error(params.alpha, d, cosine(pt.normal.xyz, c.normal.xyz));
    }
    return d;
}

@compute @workgroup_size(64)
fn rep_d2(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    atomicMin(&best_d2[l], bitcast<u32>(rep_key(points[i], centroids[l])));
}

@compute @workgroup_size(64)
fn rep_index(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    if (bitcast<u32>(rep_key(points[i], centroids[l])) == atomicLoad(&best_d2[l])) {
        atomicMin(&representatives[l], params.first + i);
    }
}
