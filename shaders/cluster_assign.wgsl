// include: common/types.wgsl common/metric.wgsl common/cluster.wgsl
// Cluster pass: each point's F nearest compatible centroids (Grid::search of
// vplgi-cpu/src/cluster.rs: the 27 cells, then widening rings, then the nearest by position),
// with their weights (Eq. 10 or Eq. 8's plain mean) and how the search ended. "Nearest" is by
// Eq. 7 (squared distance, normals beyond n_t ruled out) or by Eq. 2 of Wang et al. (its error,
// searched exactly).

@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(3) var<storage, read> centroids: array<Endpoint>;
@group(0) @binding(5) var<storage, read> cell_offsets: array<u32>;
@group(0) @binding(6) var<storage, read> cell_items: array<u32>;
@group(0) @binding(7) var<storage, read_write> labels: array<u32>;          // F per point, nearest first
@group(0) @binding(8) var<storage, read_write> weights: array<f32>;         // F per point
@group(0) @binding(10) var<storage, read_write> outcome: array<u32>;        // 0 neighbourhood, 1 widened, 2 incompatible

// ---- the search (Grid::search)

// Clusters kept per point (params.f), fixed per pipeline (vplgi-gpu/src/cluster.rs compiles one
// per F on first use) so that every loop over the list has a constant trip count and the list
// lives in registers. On lavapipe a private array indexed by a variable stays in memory and is
// read and written lane by lane; this list is touched for every centroid considered.
override F: u32 = 1u;
// The metric, fixed per pipeline too (METRIC_EQ7 or METRIC_WARD): Eq. 7's pipeline carries no
// trace of Eq. 2.
override METRIC: u32 = 0u;

// The F best (distance, index) pairs so far, nearest first, ties by index; empty slots hold
// (inf, MISS), which every centroid beats.
var<private> best_d: array<f32, MAX_F>;
var<private> best_k: array<u32, MAX_F>;
// n_t of Eq. 7 and alpha of Eq. 2, read once per point instead of per centroid.
var<private> threshold: f32;
var<private> ward_alpha: f32;

// llvmpipe (lavapipe) counts the iterations of all the loops of an invocation together and,
// past 65,535, ends every loop at its next test, silently (its loop limiter). A ring walk
// through a large sparse grid (a room's visible walls in their 3-D bounding box) ran that many
// before settling, and the rest of the search then returned farther clusters, or none. So the
// walk beyond the 27 cells stops after WALK_BUDGET cells and centroids and the search scans every
// centroid instead, four per loop iteration: the scan is exact too, so the answer is the CPU's.
// The budget is a quarter of the largest that kept tests/tests/cluster.rs' long searches exact
// with K = 6,000 (8,192 did not: a unit of it costs several of lavapipe's iterations). The 27
// cells have a budget of their own, CROWDED_CENTROIDS cells and centroids, which only data with
// thousands of centroids in one neighbourhood reaches; so a search costs at most both budgets
// and a scan, and K is bounded by MAX_ASSIGN_CENTROIDS (vplgi_types::clustering says why).
const WALK_BUDGET: i32 = 2048;
var<private> walk_left: i32;
// The nearest centroid by position, kept by scan_all for points with no compatible one.
var<private> near_d: f32;
var<private> near_k: u32;

fn clear_best() {
    for (var j = 0u; j < F; j = j + 1u) {
        best_d[j] = bitcast<f32>(0x7f800000u);
        best_k[j] = MISS;
    }
}

fn count_found() -> u32 {
    var n = 0u;
    for (var j = 0u; j < F; j = j + 1u) {
        n = n + select(0u, 1u, best_k[j] != MISS);
    }
    return n;
}

// Inserts (d, k) into the sorted list, dropping its last entry: one compare-and-swap per slot,
// the same list as the CPU's sorted insertion (centroids are distinct, so no pair repeats).
fn consider(k: u32, p: vec3<f32>, n: vec3<f32>) {
    let c = centroids[k];
    var d = dist2(p, c.position.xyz);
    var kk = k;
    // Metric::key: Eq. 2's error, or Eq. 7's squared distance if the normals are compatible.
    let cos = cosine(n, c.normal.xyz);
    if (METRIC == METRIC_WARD) {
        d = ward_error(ward_alpha, d, cos);
    } else if (!(cos > threshold)) {
        return;
    }
    for (var j = 0u; j < F; j = j + 1u) {
        let better = d < best_d[j] || (d == best_d[j] && kk < best_k[j]);
        let od = best_d[j];
        let ok = best_k[j];
        best_d[j] = select(od, d, better);
        best_k[j] = select(ok, kk, better);
        d = select(d, od, better);
        kk = select(kk, ok, better);
    }
}

// The run of `len` cells from `c` along x (within one row of the grid, or a single cell that
// may lie outside it): cells are numbered x fastest and their items stored in cell order
// (cluster_grid.wgsl), so a row's items are one contiguous range whose two ends are the only
// offsets read.
fn consider_run(c: vec3<i32>, len: i32, p: vec3<f32>, n: vec3<f32>) {
    walk_left = walk_left - len;
    if (any(c < vec3<i32>(0)) || any(c >= params.dims.xyz)) {
        return;
    }
    let l = cell_linear(c);
    let first = cell_offsets[l];
    let end = cell_offsets[l + u32(len)];
    if (i32(end - first) >= walk_left) {
        // More than the search may still consider: it scans every centroid instead (search).
        walk_left = 0;
        return;
    }
    walk_left = walk_left - i32(end - first);
    for (var i = first; i < end; i = i + 1u) {
        consider(cell_items[i], p, n);
    }
}

// Grid::visit_ring: the shell at Chebyshev distance r (r = 1: all 27 cells), clipped to the
// grid; it stops where the walk's budget runs out. A row of the shell is either whole (on its
// top, bottom or sides), one run of cells, or its two end cells, two runs of one, walked by one
// loop with a stride. Loads are what the search's time goes to on lavapipe, which runs every
// branch and every loop's first iteration for all lanes of a SIMD group, masked: a cell that
// no lane finds anything in still costs a centroid's loads. The 27 cells visited one by one, and
// the end cells in a branch of their own, cost 45 cell visits; as 9 runs, 9, and a centroid
// load for each of the ~2 a cell holds. Ties and order do not matter: the list is the F best by
// key, then index, whatever the order.
fn visit_ring(c: vec3<i32>, r: i32, p: vec3<f32>, n: vec3<f32>) {
    let lo = max(c - vec3<i32>(r), vec3<i32>(0));
    let hi = min(c + vec3<i32>(r), params.dims.xyz - vec3<i32>(1));
    for (var z = lo.z; z <= hi.z && walk_left > 0; z = z + 1) {
        for (var y = lo.y; y <= hi.y && walk_left > 0; y = y + 1) {
            let whole = r == 1 || abs(z - c.z) == r || abs(y - c.y) == r;
            let len = select(1, hi.x - lo.x + 1, whole);
            let x_end = select(c.x + r, lo.x, whole);
            let stride = select(2 * r, len, whole);
            for (var x = select(c.x - r, lo.x, whole); x <= x_end && walk_left > 0; x = x + stride) {
                consider_run(vec3<i32>(x, y, z), len, p, n);
            }
        }
    }
}

// Metric::settled: nothing at least `reach` away can beat a key of `key`.
fn settled(key: f32, reach: f32) -> bool {
    if (METRIC == METRIC_WARD) {
        return key <= ward_alpha * reach;
    }
    return sqrt(key) <= reach;
}

// Whether the F-th best is settled against everything `reach` away or farther.
fn list_settled(reach: f32) -> bool {
    return best_k[F - 1u] != MISS && settled(best_d[F - 1u], reach);
}

// Returns 0 (neighbourhood), 1 (widened) or 2 (no compatible centroid: nearest by position).
// The 27 cells and the widening rings are one loop, and every way of giving up on the rings
// ends at the one scan of all centroids after it: on lavapipe a loop or call that no lane of a
// SIMD group needs still runs once with every lane masked, so a separate ring walk and two
// scans cost every point a ring and two scans' worth of masked loads.
fn search(p: vec3<f32>, n: vec3<f32>) -> u32 {
    clear_best();
    let c = cell_coords(p);
    let far = max(c, params.dims.xyz - vec3<i32>(1) - c);
    let last = max(max(max(far.x, far.y), far.z), 1);
    // The 27 cells are visited whole (Eq. 7's answer is what they hold) unless they are crowded
    // (Grid::search): then every centroid is scanned, a quarter of the loop iterations each.
    walk_left = i32(CROWDED_CENTROIDS);
    var r = 1;
    loop {
        visit_ring(c, r, p, n);
        if (r == 1) {
            if (walk_left <= 0) {
                break;
            }
            // Eq. 7 keeps the paper's approximation (whatever the 27 cells hold); Eq. 2 is
            // exact.
            if (METRIC == METRIC_WARD) {
                if (list_settled(params.origin.w)) {
                    return 0u;
                }
            } else if (best_k[0] != MISS) {
                return 0u;
            }
            walk_left = WALK_BUDGET;
        } else if (walk_left > 0) {
            // Exact F nearest once the F-th best is nearer than anything in the unvisited
            // rings.
            if (list_settled(f32(r) * params.origin.w)) {
                return 1u;
            }
        } else {
            // Out of budget (the last ring may be incomplete): every centroid instead.
            break;
        }
        r = r + 1;
        if (r > last) {
            if (best_k[0] != MISS) {
                return 1u;
            }
            // The whole grid walked and no compatible centroid: the scan finds the nearest by
            // position.
            break;
        }
        if (r >= params.dims.w) {
            // The rings now hold more cells than there are centroids: every centroid instead.
            break;
        }
    }
    return select(2u, 1u, scan_all(p, n));
}

fn scan_one(k: u32, p: vec3<f32>, n: vec3<f32>) {
    consider(k, p, n);
    let d = dist2(p, centroids[k].position.xyz);
    if (d < near_d) {
        near_d = d;
        near_k = k;
    }
}

// The F nearest compatible centroids of all, or, if none is compatible (returns false), the
// nearest by position in best_*[0]. Four centroids per iteration, against lavapipe's loop
// limiter.
fn scan_all(p: vec3<f32>, n: vec3<f32>) -> bool {
    clear_best();
    near_d = bitcast<f32>(0x7f800000u);
    near_k = MISS;
    var k = 0u;
    for (; k + 4u <= params.k; k = k + 4u) {
        scan_one(k, p, n);
        scan_one(k + 1u, p, n);
        scan_one(k + 2u, p, n);
        scan_one(k + 3u, p, n);
    }
    for (; k < params.k; k = k + 1u) {
        scan_one(k, p, n);
    }
    if (best_k[0] != MISS) {
        return true;
    }
    best_d[0] = near_d;
    best_k[0] = near_k;
    return false;
}

@compute @workgroup_size(64)
fn assign(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    threshold = params.threshold;
    ward_alpha = params.alpha;
    let pt = points[i];
    let how = search(pt.position.xyz, pt.normal.xyz);
    outcome[i] = how;
    let found = count_found();
    // fuzzy_weights: inverse distance or Eq. 2 error (Metric::weight_distance: floored at
    // 1e-4 cell), or plain mean, normalised.
    var floor_d = 1e-4 * params.origin.w;
    if (METRIC == METRIC_WARD) {
        floor_d = 1e-4 * (ward_alpha * params.origin.w);
    }
    var w: array<f32, MAX_F>;
    var total = 0.0;
    for (var j = 0u; j < F; j = j + 1u) {
        if (j < found) {
            if (params.fuzzy == WEIGHTS_INVERSE_DISTANCE) {
                if (METRIC == METRIC_WARD) {
                    w[j] = 1.0 / max(best_d[j], floor_d);
                } else {
                    w[j] = 1.0 / max(sqrt(best_d[j]), floor_d);
                }
            } else {
                w[j] = 1.0;
            }
            total = total + w[j];
        }
    }
    let inf = bitcast<f32>(0x7f800000u);
    if (!(total < inf && total > 0.0)) {
        total = f32(found);
        for (var j = 0u; j < F; j = j + 1u) {
            w[j] = 1.0;
        }
    }
    for (var j = 0u; j < F; j = j + 1u) {
        if (j < found) {
            labels[i * F + j] = best_k[j];
            weights[i * F + j] = w[j] / total;
        } else {
            labels[i * F + j] = MISS;
            weights[i * F + j] = 0.0;
        }
    }
}
