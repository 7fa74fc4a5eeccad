// Shared by the clustering passes (cluster_*.wgsl; host side vplgi-gpu/src/cluster.rs): the
// parameters every pass reads and the grid's cells (the metrics are in common/metric.wgsl).
// Per-point arrays are bound as windows of at most one storage binding (buffers.rs, Window);
// per-point entry points see the window's points as 0 .. n.

struct Params {
    origin: vec4<f32>,      // grid origin (xyz), w = cell size
    dims: vec4<i32>,        // grid dims (xyz), w = ring from which the search scans all centroids
    fix_min: vec4<f32>,     // fixed-point box minimum (xyz)
    fix_ext: vec4<f32>,     // fixed-point box extent (xyz)
    n: u32,                 // points (or sample points / cells / centroids, per entry point)
    k: u32,                 // centroids
    f: u32,                 // entries per point in `labels`
    threshold: f32,         // n_t of Eq. 7
    fuzzy: u32,             // 0 hard/average weights (plain mean), 1 inverse distance
    cells: u32,             // cells of the grid (or bitmap words)
    first: u32,             // global index of the bound window's first point
    window: u32,            // points in the bound window (gather)
    alpha: f32,             // alpha of Eq. 2 (Wang et al.) per unit length
    representative: u32,    // REPRESENTATIVE_NEAREST or REPRESENTATIVE_MIN_ERROR
    metric: u32,            // METRIC_EQ7 or METRIC_WARD, where read as data (cluster_temporal.wgsl)
    pad: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;

fn cell_coords(p: vec3<f32>) -> vec3<i32> {
    let q = (p - params.origin.xyz) / params.origin.w;
    return clamp(vec3<i32>(floor(q)), vec3<i32>(0), params.dims.xyz - vec3<i32>(1));
}

fn cell_linear(c: vec3<i32>) -> u32 {
    return u32(c.x) + u32(params.dims.x) * (u32(c.y) + u32(params.dims.y) * u32(c.z));
}
