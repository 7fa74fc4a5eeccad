// Stage 3, cluster (vplgi-cpu/src/cluster.rs) on the GPU: the data-parallel parts of Alg. 1 and
// Alg. 2. The host (vplgi-gpu/src/cluster.rs) sequences the entry points and makes the choices
// shared with the CPU (vplgi_types::clustering): downsampled set, seeds, grid geometry, fixed-point
// format. Points and centroids are Endpoints (position, normal). Per-point arrays (points,
// labels, weights, outcome) are bound as windows of at most one storage binding (buffers.rs,
// Window); per-point entry points see the window's points as 0 .. n.
//
//   occupancy, count_bits        cells occupied by the sample for a candidate cell size
//   grid_count, grid_scatter     counting sort of centroids into cells (around scan.wgsl)
//   assign                       F nearest compatible centroids (27 cells, widened, fallback)
//   sums, finalize               fixed-point centroid update with 64-bit sums in u32 pairs
//   rep_d2, rep_index            representatives: the member nearest its centroid
//   gather, bounds, count_labels, flags, compact, outcome_counts: seeding, the data's box,
//                                member counts and the removal of empty clusters

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
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(2) var<storage, read> index: array<u32>;          // gather: point indices
@group(0) @binding(3) var<storage, read_write> centroids: array<Endpoint>;
@group(0) @binding(4) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> offsets: array<u32>;
@group(0) @binding(6) var<storage, read_write> items: array<u32>;
@group(0) @binding(7) var<storage, read_write> labels: array<u32>;
@group(0) @binding(8) var<storage, read_write> weights: array<f32>;
@group(0) @binding(9) var<storage, read_write> sums: array<atomic<u32>>; // 12 per cluster + total
@group(0) @binding(10) var<storage, read_write> outcome: array<u32>;     // per point: 0, 1 widened, 2 incompatible
@group(0) @binding(11) var<storage, read_write> compacted: array<Endpoint>;

fn dist2(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let dx = a.x - b.x;
    let dy = a.y - b.y;
    let dz = a.z - b.z;
    var s = dx * dx;
    s = s + dy * dy;
    s = s + dz * dz;
    return s;
}

fn compatible(n: vec3<f32>, m: vec3<f32>) -> bool {
    var d = n.x * m.x;
    d = d + n.y * m.y;
    d = d + n.z * m.z;
    return d > params.threshold;
}

fn cell_coords(p: vec3<f32>) -> vec3<i32> {
    let q = (p - params.origin.xyz) / params.origin.w;
    return clamp(vec3<i32>(floor(q)), vec3<i32>(0), params.dims.xyz - vec3<i32>(1));
}

fn cell_linear(c: vec3<i32>) -> u32 {
    return u32(c.x) + u32(params.dims.x) * (u32(c.y) + u32(params.dims.y) * u32(c.z));
}

// ---- occupancy of a candidate cell size (params.origin.w), over the sample points (params.n)

@compute @workgroup_size(64)
fn occupancy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = thread_index(gid, groups);
    if (s >= params.n) {
        return;
    }
    let p = points[s].position.xyz;
    let q = vec3<u32>(floor((p - params.origin.xyz) / params.origin.w));
    let lin = q.x + u32(params.dims.x) * (q.y + u32(params.dims.y) * q.z);
    atomicOr(&sums[lin / 32u], 1u << (lin % 32u));
}

@compute @workgroup_size(64)
fn count_bits(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let w = thread_index(gid, groups);
    if (w >= params.cells) {
        return;
    }
    let bits = countOneBits(atomicLoad(&sums[w]));
    if (bits > 0u) {
        atomicAdd(&counts[0], bits);
    }
}

// ---- grid fill: counts per cell, scan, scatter (order inside a cell is irrelevant: the search
// breaks ties on the centroid index)

@compute @workgroup_size(64)
fn grid_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    atomicAdd(&counts[cell_linear(cell_coords(centroids[k].position.xyz))], 1u);
}

@compute @workgroup_size(64)
fn grid_scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    let c = cell_linear(cell_coords(centroids[k].position.xyz));
    // `sums` serves as the per-cell cursor here.
    let slot = atomicAdd(&sums[c], 1u);
    items[offsets[c] + slot] = k;
}

// ---- the search (Grid::search)

var<private> best_d: array<f32, 16>;
var<private> best_k: array<u32, 16>;
var<private> found: u32;

fn consider(k: u32, p: vec3<f32>, n: vec3<f32>) {
    let c = centroids[k];
    if (!compatible(n, c.normal.xyz)) {
        return;
    }
    let d = dist2(p, c.position.xyz);
    var pos = found;
    while (pos > 0u && (d < best_d[pos - 1u] || (d == best_d[pos - 1u] && k < best_k[pos - 1u]))) {
        pos = pos - 1u;
    }
    if (pos < params.f) {
        let end = min(found, params.f - 1u);
        for (var j = end; j > pos; j = j - 1u) {
            best_d[j] = best_d[j - 1u];
            best_k[j] = best_k[j - 1u];
        }
        best_d[pos] = d;
        best_k[pos] = k;
        found = min(found + 1u, params.f);
    }
}

fn consider_cell(c: vec3<i32>, p: vec3<f32>, n: vec3<f32>) {
    if (any(c < vec3<i32>(0)) || any(c >= params.dims.xyz)) {
        return;
    }
    let l = cell_linear(c);
    for (var i = offsets[l]; i < offsets[l + 1u]; i = i + 1u) {
        consider(items[i], p, n);
    }
}

// Grid::visit_ring: the shell at Chebyshev distance r (r = 1: all 27 cells), clipped to the grid.
fn visit_ring(c: vec3<i32>, r: i32, p: vec3<f32>, n: vec3<f32>) {
    let lo = max(c - vec3<i32>(r), vec3<i32>(0));
    let hi = min(c + vec3<i32>(r), params.dims.xyz - vec3<i32>(1));
    for (var z = lo.z; z <= hi.z; z = z + 1) {
        for (var y = lo.y; y <= hi.y; y = y + 1) {
            if (r == 1 || abs(z - c.z) == r || abs(y - c.y) == r) {
                for (var x = lo.x; x <= hi.x; x = x + 1) {
                    consider_cell(vec3<i32>(x, y, z), p, n);
                }
            } else {
                consider_cell(vec3<i32>(c.x - r, y, z), p, n);
                consider_cell(vec3<i32>(c.x + r, y, z), p, n);
            }
        }
    }
}

// Returns 0 (neighbourhood), 1 (widened) or 2 (no compatible centroid: nearest by position).
fn search(p: vec3<f32>, n: vec3<f32>) -> u32 {
    found = 0u;
    let c = cell_coords(p);
    visit_ring(c, 1, p, n);
    if (found > 0u) {
        return 0u;
    }
    let far = max(c, params.dims.xyz - vec3<i32>(1) - c);
    let last = max(max(max(far.x, far.y), far.z), 1);
    for (var r = 2; r <= last; r = r + 1) {
        if (r >= params.dims.w) {
            found = 0u;
            for (var k = 0u; k < params.k; k = k + 1u) {
                consider(k, p, n);
            }
            break;
        }
        visit_ring(c, r, p, n);
        if (found > 0u && sqrt(best_d[0]) <= f32(r) * params.origin.w) {
            return 1u;
        }
    }
    if (found > 0u) {
        return 1u;
    }
    var nd = bitcast<f32>(0x7f800000u);
    var nk = MISS;
    for (var k = 0u; k < params.k; k = k + 1u) {
        let d = dist2(p, centroids[k].position.xyz);
        if (d < nd) {
            nd = d;
            nk = k;
        }
    }
    if (nk != MISS) {
        best_d[0] = nd;
        best_k[0] = nk;
        found = 1u;
    }
    return 2u;
}

@compute @workgroup_size(64)
fn assign(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let pt = points[i];
    let how = search(pt.position.xyz, pt.normal.xyz);
    outcome[i] = how;
    // fuzzy_weights: inverse distance (floored at 1e-4 cell) or plain mean, normalised.
    let floor_d = 1e-4 * params.origin.w;
    var w: array<f32, 16>;
    var total = 0.0;
    for (var j = 0u; j < found; j = j + 1u) {
        if (params.fuzzy == WEIGHTS_INVERSE_DISTANCE) {
            w[j] = 1.0 / max(sqrt(best_d[j]), floor_d);
        } else {
            w[j] = 1.0;
        }
        total = total + w[j];
    }
    let inf = bitcast<f32>(0x7f800000u);
    if (!(total < inf && total > 0.0)) {
        total = f32(found);
        for (var j = 0u; j < found; j = j + 1u) {
            w[j] = 1.0;
        }
    }
    for (var j = 0u; j < params.f; j = j + 1u) {
        if (j < found) {
            labels[i * params.f + j] = best_k[j];
            weights[i * params.f + j] = w[j] / total;
        } else {
            labels[i * params.f + j] = MISS;
            weights[i * params.f + j] = 0.0;
        }
    }
}

// ---- centroid update (FixedPoint): 64-bit sums as (lo, hi) u32 pairs with a carry.

fn add64(slot: u32, v: u32) {
    let old = atomicAdd(&sums[slot], v);
    if (old > 0xffffffffu - v) {
        atomicAdd(&sums[slot + 1u], 1u);
    }
}

@compute @workgroup_size(64)
fn sums_kernel(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    if (l == MISS) {
        return;
    }
    let pt = points[i];
    let q = clamp((pt.position.xyz - params.fix_min.xyz) / params.fix_ext.xyz * FIX_ONE, vec3<f32>(0.0), vec3<f32>(FIX_ONE));
    let m = clamp(clamp(pt.normal.xyz, vec3<f32>(-1.0), vec3<f32>(1.0)) * FIX_ONE + FIX_ONE, vec3<f32>(0.0), vec3<f32>(2.0 * FIX_ONE));
    let qu = vec3<u32>(round(q));
    let mu = vec3<u32>(round(m));
    let base = l * 12u;
    add64(base + 0u, qu.x);
    add64(base + 2u, qu.y);
    add64(base + 4u, qu.z);
    add64(base + 6u, mu.x);
    add64(base + 8u, mu.y);
    add64(base + 10u, mu.z);
    atomicAdd(&counts[l], 1u);
}

fn mean64(slot: u32, count: u32) -> f32 {
    let lo = atomicLoad(&sums[slot]);
    let hi = atomicLoad(&sums[slot + 1u]);
    return (f32(hi) * 4294967296.0 + f32(lo)) / f32(count);
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
    let m = vec3<f32>(mean64(base, count), mean64(base + 2u, count), mean64(base + 4u, count));
    let mn = vec3<f32>(mean64(base + 6u, count), mean64(base + 8u, count), mean64(base + 10u, count));
    centroids[k].position = vec4<f32>(params.fix_min.xyz + m / FIX_ONE * params.fix_ext.xyz, 0.0);
    let nrm = (mn - vec3<f32>(FIX_ONE)) / FIX_ONE;
    // glam try_normalize: 1 / length must be finite and positive.
    let rcp = 1.0 / sqrt(dot(nrm, nrm));
    if (rcp < bitcast<f32>(0x7f800000u) && rcp > 0.0) {
        centroids[k].normal = vec4<f32>(nrm * rcp, 0.0);
    }
}

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
    atomicMin(&counts[l], bitcast<u32>(d));
}

@compute @workgroup_size(64)
fn rep_index(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[i * params.f];
    let d = dist2(points[i].position.xyz, centroids[l].position.xyz);
    if (bitcast<u32>(d) == atomicLoad(&counts[l])) {
        atomicMin(&sums[l], params.first + i);
    }
}

// ---- small helpers

// centroids[t] = points[index[t]] for the indices that fall in the bound window of points
// (params.first .. + params.window); `index` and `centroids` are windows of params.n items.
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
        centroids[t] = points[p - params.first];
    }
}

// Bounds of the points as order-preserving u32 keys: sums[0..3] = min, sums[3..6] = max.
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
        atomicMin(&sums[a], order_key(p[a]));
        atomicMax(&sums[3u + a], order_key(p[a]));
    }
}

// Members per cluster from the first label.
@compute @workgroup_size(64)
fn count_labels(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    atomicAdd(&counts[labels[i * params.f]], 1u);
}

// 1 for a non-empty cluster, 0 for an empty one, into `sums` (the host then scans that buffer,
// bound as `counts`, to number the survivors).
@compute @workgroup_size(64)
fn flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    atomicStore(&sums[k], select(0u, 1u, atomicLoad(&counts[k]) > 0u));
}

// Surviving centroids, renumbered by the scan of the flags (in `offsets`), go to `compacted`;
// their member counts to `items`.
@compute @workgroup_size(64)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.k) {
        return;
    }
    let c = atomicLoad(&counts[k]);
    if (c > 0u) {
        compacted[offsets[k]] = centroids[k];
        items[offsets[k]] = c;
    }
}

// How the searches ended: counts[0] neighbourhood, [1] widened, [2] incompatible.
@compute @workgroup_size(64)
fn outcome_counts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    atomicAdd(&counts[outcome[i]], 1u);
}
