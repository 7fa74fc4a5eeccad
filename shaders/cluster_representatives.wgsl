// Cluster pass: each cluster's representative, the member (by first label) nearest its centroid.

@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(3) var<storage, read> centroids: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> best_d2: array<atomic<u32>>;          // per cluster, as f32 bits
@group(0) @binding(7) var<storage, read> labels: array<u32>;
@group(0) @binding(9) var<storage, read_write> representatives: array<atomic<u32>>;  // per cluster: a point index

// ---- representatives: per cluster the member (by first label) nearest the centroid, ties to
// the lower index: first the minimum distance (as ordered bits of a non-negative float), then
// the lowest index among the points at that distance.

@compute @workgroup_size(64)
fn rep_d2(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    let d = dist2(points[i].position.xyz, centroids[l].position.xyz);
    atomicMin(&best_d2[l], bitcast<u32>(d));
}

@compute @workgroup_size(64)
fn rep_index(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    let d = dist2(points[i].position.xyz, centroids[l].position.xyz);
    if (bitcast<u32>(d) == atomicLoad(&best_d2[l])) {
        atomicMin(&representatives[l], params.first + i);
    }
}
