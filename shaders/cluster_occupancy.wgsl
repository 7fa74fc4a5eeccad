// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
// Cluster pass: how many grid cells a candidate cell size (params.origin.w) occupies, over the
// downsampled points (vplgi_types::clustering::grid_geometry chooses the size from the counts).

@group(0) @binding(1) var<storage, read> sample: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> occupied: array<atomic<u32>>;   // [0]: occupied cells
@group(0) @binding(9) var<storage, read_write> bitmap: array<atomic<u32>>;     // a bit per cell

@compute @workgroup_size(64)
fn occupancy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = thread_index(gid, groups);
    if (s >= params.n) {
        return;
    }
    let p = sample[s].position.xyz;
    let q = vec3<u32>(floor((p - params.origin.xyz) / params.origin.w));
    let lin = q.x + u32(params.dims.x) * (q.y + u32(params.dims.y) * q.z);
    atomicOr(&bitmap[lin / 32u], 1u << (lin % 32u));
}

@compute @workgroup_size(64)
fn count_bits(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let w = thread_index(gid, groups);
    if (w >= params.cells) {
        return;
    }
    let bits = countOneBits(atomicLoad(&bitmap[w]));
    if (bits > 0u) {
        atomicAdd(&occupied[0], bits);
    }
}
