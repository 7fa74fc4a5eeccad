// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
// Cluster pass: dropping the clusters nobody is nearest to after the final hard assignment.

@group(0) @binding(3) var<storage, read> centroids: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> members: array<atomic<u32>>;     // per cluster
@group(0) @binding(5) var<storage, read> remap: array<u32>;                      // exclusive scan of the flags
@group(0) @binding(6) var<storage, read_write> survivor_members: array<u32>;
@group(0) @binding(7) var<storage, read> labels: array<u32>;
@group(0) @binding(9) var<storage, read_write> flags_out: array<u32>;
@group(0) @binding(11) var<storage, read_write> survivors: array<Endpoint>;
@group(0) @binding(12) var<storage, read_write> relabelled: array<u32>;

// Members per cluster from the first label.
@compute @workgroup_size(64)
fn count_labels(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    atomicAdd(&members[labels[i * params.f]], 1u);
}

// 1 for a non-empty cluster, 0 for an empty one (the host scans the flags into `remap` to
// number the survivors).
@compute @workgroup_size(64)
fn flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    flags_out[k] = select(0u, 1u, atomicLoad(&members[k]) > 0u);
}

// Surviving centroids, renumbered by the scan of the flags (`remap`), go to `survivors`; their
// member counts to `survivor_members`.
@compute @workgroup_size(64)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    let c = atomicLoad(&members[k]);
    if (c > 0u) {
        survivors[remap[k]] = centroids[k];
        survivor_members[remap[k]] = c;
    }
}

// With F = 1 the fuzzy assignment against the survivors would find each point's hard label again
// (its cluster survived), so the hard labels are renumbered instead (vplgi_cpu::cluster reuses
// the hard pass the same way).
@compute @workgroup_size(64)
fn relabel(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    relabelled[i] = remap[labels[i]];
}
