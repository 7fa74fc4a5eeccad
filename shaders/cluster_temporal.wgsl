// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
// Cluster passes of `--temporal on` (vplgi-cpu/src/cluster/temporal.rs): each point against
// its nearest previous centre (admitted when its key is at most the centre's threshold), and
// each cluster's largest member key, the next frame's threshold.

@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(3) var<storage, read> centroids: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> per_cluster: array<atomic<u32>>;  // admitted counts, or largest keys as f32 bits
@group(0) @binding(5) var<storage, read> thresholds: array<f32>;
@group(0) @binding(7) var<storage, read> labels: array<u32>;
@group(0) @binding(10) var<storage, read_write> unfit: array<u32>;

// Metric::key (vplgi-types/src/clustering.rs): Eq. 2's error, or Eq. 7's squared distance;
// -1 where Eq. 7 rules the pair out (keys are never negative).
fn metric_key(pt: Endpoint, c: Endpoint) -> f32 {
    let d = dist2(pt.position.xyz, c.position.xyz);
    let cos = cosine(pt.normal.xyz, c.normal.xyz);
    if (params.metric == METRIC_WARD) {
        return ward_error(params.alpha, d, cos);
    }
    if (cos > params.threshold) {
        return d;
    }
    return -1.0;
}

@compute @workgroup_size(64)
fn admit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i];
    var fits = false;
    if (l != MISS) {
        let key = metric_key(points[i], centroids[l]);
        fits = key >= 0.0 && key <= thresholds[l];
    }
    if (fits) {
        atomicAdd(&per_cluster[l], 1u);
    }
    unfit[i] = select(1u, 0u, fits);
}

// Keys are non-negative, so their bits order like their values.
@compute @workgroup_size(64)
fn largest_key(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    let key = metric_key(points[i], centroids[l]);
    if (key >= 0.0) {
        atomicMax(&per_cluster[l], bitcast<u32>(key));
    }
}
