// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
// Cluster pass: the grid over the centroids, filled by a counting sort (count per cell, a scan
// on the host's ScanKernel, scatter).

@group(0) @binding(3) var<storage, read> centroids: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> cell_counts: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read> cell_offsets: array<u32>;              // exclusive scan of cell_counts
@group(0) @binding(6) var<storage, read_write> cell_items: array<u32>;          // centroid indices by cell
@group(0) @binding(9) var<storage, read_write> cursor: array<atomic<u32>>;      // per cell, from 0

// ---- grid fill: counts per cell, scan, scatter (order inside a cell is irrelevant: the search
// breaks ties on the centroid index)

@compute @workgroup_size(64)
fn grid_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    atomicAdd(&cell_counts[cell_linear(cell_coords(centroids[k].position.xyz))], 1u);
}

@compute @workgroup_size(64)
fn grid_scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    let c = cell_linear(cell_coords(centroids[k].position.xyz));
    let slot = atomicAdd(&cursor[c], 1u);
    cell_items[cell_offsets[c] + slot] = k;
}
