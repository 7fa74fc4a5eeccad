// Cluster pass: each point's F nearest compatible centroids (Grid::search of
// vplgi-cpu/src/cluster.rs: the 27 cells, then widening rings, then the nearest by position),
// with their weights (Eq. 10 or Eq. 8's plain mean) and how the search ended.

@group(0) @binding(1) var<storage, read> points: array<Endpoint>;
@group(0) @binding(3) var<storage, read> centroids: array<Endpoint>;
@group(0) @binding(5) var<storage, read> cell_offsets: array<u32>;
@group(0) @binding(6) var<storage, read> cell_items: array<u32>;
@group(0) @binding(7) var<storage, read_write> labels: array<u32>;          // F per point, nearest first
@group(0) @binding(8) var<storage, read_write> weights: array<f32>;         // F per point
@group(0) @binding(10) var<storage, read_write> outcome: array<u32>;        // 0 neighbourhood, 1 widened, 2 incompatible

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
    for (var i = cell_offsets[l]; i < cell_offsets[l + 1u]; i = i + 1u) {
        consider(cell_items[i], p, n);
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
        // Exact F nearest once the F-th best is nearer than anything in the unvisited rings.
        if (found == params.f && sqrt(best_d[params.f - 1u]) <= f32(r) * params.origin.w) {
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
