// include: common/types.wgsl
// VPL clustering in reflective-shadow-map space (vplgi-cpu/src/rsm_cluster.rs; Prutkin et al.
// 2012, Alg. 1), one kernel per step:
//   map_starts:  the first VPL of each map (VPLs are in texel order);
//   importance_max, importance_rows, importance_cumulate, importance_cap (with an importance
//                map): each map's largest importance, its texels' integer weights summed by row,
//                the rows' running totals, the cap of one seed's share, recomputed CAP_PASSES
//                times (vplgi_shared::rsm_importance::map_weights);
//   seed:        cluster j of map m starts at the VPL at or after Halton texel j - first + 1,
//                warped by the map's weights when there are any (rsm_importance::warp), unless
//                its slot holds a cluster of the previous frame (--temporal on);
//   grid_count, grid_fill (around scan.wgsl): the clusters of each cell of each map's grid;
//   assign:      each VPL's cluster of smallest Eq. 1 within r = 2 cells (ties: lower index);
//   radix_flags, radix_scatter (around scan.wgsl), one bit per pass: a stable sort of the VPL
//                indices by cluster, so each cluster's members are contiguous, in texel order;
//   ranges:      each cluster's run in the sorted order;
//   update:      each cluster's flux-weighted centre and normal, chroma and map position, summed
//                over its run in order (the CPU's order: the same float sums);
//   representatives: each cluster's member nearest its centre (ties: lower index);
//   kept_flags, compact (around scan.wgsl): empty clusters dropped, labels renumbered.

struct Params {
    n: u32,           // VPLs
    maps: u32,
    k: u32,           // clusters over all maps
    bit: u32,         // radix pass
    w_position: f32,
    w_normal: f32,
    w_flux: f32,
    inv_extent: f32,
    importance: u32,  // 1: seeds warped by the importance map
    rows: u32,        // rows over all maps
    first: u32,       // update, representatives: the members [first, first + chunk) of each run
    chunk: u32,
}

// One map's share of the VPLs, clusters and grid cells.
struct MapInfo {
    vpl_start: u32,
    vpl_end: u32,
    cluster_first: u32,
    k: u32,
    grid: u32,
    cell_first: u32,
    row_first: u32,   // the map's first row among all maps' rows
    pad1: u32,
}

struct ClusterState {
    centre: vec3<f32>,
    texel_x: f32,
    normal: vec3<f32>,
    texel_y: f32,
    chroma: vec3<f32>,
    map: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> maps: array<RsmLight>;
@group(0) @binding(2) var<storage, read> info: array<MapInfo>;
@group(0) @binding(3) var<storage, read> vpls: array<Vpl>;
@group(0) @binding(4) var<storage, read_write> states: array<ClusterState>;
@group(0) @binding(5) var<storage, read_write> counts: array<atomic<u32>>;   // per cell; per cursor
@group(0) @binding(6) var<storage, read> offsets: array<u32>;                // exclusive scans
@group(0) @binding(7) var<storage, read_write> items: array<u32>;            // cell items; sorted order
@group(0) @binding(8) var<storage, read_write> labels: array<u32>;
@group(0) @binding(9) var<storage, read_write> order: array<u32>;            // radix input
@group(0) @binding(10) var<storage, read_write> flags: array<u32>;
@group(0) @binding(11) var<storage, read_write> ranges: array<vec2<u32>>;
@group(0) @binding(12) var<storage, read_write> reps: array<u32>;
@group(0) @binding(13) var<storage, read_write> starts: array<u32>;
@group(0) @binding(14) var<storage, read_write> centroids: array<Endpoint>;
@group(0) @binding(15) var<storage, read_write> kept_reps: array<u32>;
@group(0) @binding(16) var<storage, read> importance: array<f32>;          // per texel
@group(0) @binding(17) var<storage, read_write> map_max: array<atomic<u32>>; // bits of the largest
@group(0) @binding(18) var<storage, read_write> rows: array<u32>;          // row sums, then totals
@group(0) @binding(19) var<storage, read> live: array<u32>;                // 1: a previous cluster's slot
@group(0) @binding(20) var<storage, read_write> map_cap: array<u32>;       // largest texel weight
// update: each cluster's running sums between its member ranges (Σ w x, Σ w; Σ w n, Σ texel.x;
// Σ flux, Σ texel.y); representatives: its nearest distance so far in [0].x.
@group(0) @binding(21) var<storage, read_write> running: array<vec4<f32>>;


// rsm::chroma
fn chroma(flux: vec3<f32>) -> vec3<f32> {
    let len = length(flux);
    if (len > 0.0) {
        return flux / len;
    }
    return vec3<f32>(0.0);
}

// rsm::mu (Eq. 1)
fn mu(dx: vec3<f32>, np: vec3<f32>, nc: vec3<f32>, cp: vec3<f32>, cc: vec3<f32>) -> f32 {
    let dc = cp - cc;
    return params.w_position * dot(dx, dx) + params.w_normal * (1.0 - dot(np, nc)) + params.w_flux * dot(dc, dc);
}

// The first index in [lo, hi) whose VPL's texel is at or after `t` (VPLs in texel order).
fn vpl_at_or_after(lo_in: u32, hi_in: u32, t: u32) -> u32 {
    var lo = lo_in;
    var hi = hi_in;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (vpls[mid].path < t) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// The map of VPL i: the last map whose VPLs start at or before i.
fn map_of_vpl(i: u32) -> u32 {
    var lo = 0u;
    var hi = params.maps;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (info[mid].vpl_start <= i) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return max(lo, 1u) - 1u;
}

// MapClusters::texel
fn texel_of(v: Vpl, m: RsmLight) -> vec2<f32> {
    let k = v.path - m.first;
    return vec2<f32>(f32(k % m.size) + 0.5, f32(k / m.size) + 0.5);
}

// MapClusters::cell
fn cell_of(texel: vec2<f32>, m: RsmLight, grid: u32) -> vec2<i32> {
    let f = f32(grid) / f32(m.size);
    let g = i32(grid) - 1;
    return vec2<i32>(clamp(i32(texel.x * f), 0, g), clamp(i32(texel.y * f), 0, g));
}

@compute @workgroup_size(64)
fn map_starts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = thread_index(gid, groups);
    if (m > params.maps) {
        return;
    }
    if (m == params.maps) {
        starts[m] = params.n;
        return;
    }
    starts[m] = vpl_at_or_after(0u, params.n, maps[m].first);
}

// rsm::halton_texel
fn halton_texel(i: u32, n: u32) -> vec2<u32> {
    let x2 = reverseBits(i) >> 12u;
    var x3 = 0u;
    var j = i;
    for (var d = 0u; d < 12u; d = d + 1u) {
        x3 = x3 * 3u + j % 3u;
        j = j / 3u;
    }
    // x2 < 2^20 and x3 < 3^12 < 2^20, n <= 4096 = 2^12: the products fit 32 bits.
    return vec2<u32>((x2 * n) >> 20u, (x3 * n) / 531441u);
}

// rsm_importance::halton_fractions: point i of the 2-D Halton sequence as two 20-bit fractions.
fn halton_fractions(i: u32) -> vec2<u32> {
    var x3 = 0u;
    var j = i;
    for (var d = 0u; d < 12u; d = d + 1u) {
        x3 = x3 * 3u + j % 3u;
        j = j / 3u;
    }
    var f3 = 0u;
    var r = x3;
    for (var b = 0u; b < 20u; b = b + 1u) {
        r = r * 2u;
        f3 = f3 * 2u;
        if (r >= 531441u) {
            r = r - 531441u;
            f3 = f3 + 1u;
        }
    }
    return vec2<u32>(reverseBits(i) >> 12u, f3);
}

// rsm_importance::scale_fraction: floor(f n / 2^20), the 64-bit product from 16-bit limbs.
fn scale_fraction(f: u32, n: u32) -> u32 {
    let a0 = f & 0xffffu;
    let a1 = f >> 16u;
    let b0 = n & 0xffffu;
    let b1 = n >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    let lo = (p00 & 0xffffu) | (mid << 16u);
    let hi = a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    return (hi << 12u) | (lo >> 20u);
}

// rsm_importance::quantum_bits and quantum_scale: the power of two that puts the map's largest
// importance (bits `max_bits`) in [2^(bits-1), 2^bits).
fn quantum_scale(max_bits: u32, texels: u32) -> f32 {
    let ceil_log2 = 32u - countLeadingZeros(texels - select(0u, 1u, texels > 0u));
    let bits = min(31u - min(ceil_log2, 31u), 24u);
    let exponent = i32((max_bits >> 23u) & 0xffu) - 127;
    let e = clamp(i32(bits) - 1 - exponent, -126, 127);
    return bitcast<f32>(u32(e + 127) << 23u);
}

// rsm_importance::quantize, 0 for a texel without importance, capped at `cap`.
fn weight(t: u32, scale: f32, cap: u32) -> u32 {
    let x = importance[t];
    if (x > 0.0) {
        return min(u32(ceil(x * scale)), cap);
    }
    return 0u;
}

// The map holding global row r: the last whose rows start at or before it.
fn map_of_row(r: u32) -> u32 {
    var lo = 0u;
    var hi = params.maps;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (info[mid].row_first <= r) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return max(lo, 1u) - 1u;
}

@compute @workgroup_size(64)
fn importance_max(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let x = importance[vpls[i].path];
    if (x > 0.0) {
        // Positive floats order as their bits.
        atomicMax(&map_max[map_of_vpl(i)], bitcast<u32>(x));
    }
}

@compute @workgroup_size(64)
fn importance_rows(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let r = thread_index(gid, groups);
    if (r >= params.rows) {
        return;
    }
    let mi = map_of_row(r);
    let m = maps[mi];
    let max_bits = atomicLoad(&map_max[mi]);
    var sum = 0u;
    if (max_bits != 0u) {
        let scale = quantum_scale(max_bits, m.size * m.size);
        let cap = map_cap[mi];
        let first = m.first + (r - info[mi].row_first) * m.size;
        for (var x = 0u; x < m.size; x = x + 1u) {
            sum = sum + weight(first + x, scale, cap);
        }
    }
    rows[r] = sum;
}

@compute @workgroup_size(64)
fn importance_cumulate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let mi = thread_index(gid, groups);
    if (mi >= params.maps) {
        return;
    }
    let first = info[mi].row_first;
    var acc = 0u;
    for (var y = 0u; y < maps[mi].size; y = y + 1u) {
        acc = acc + rows[first + y];
        rows[first + y] = acc;
    }
}

// rsm_importance::weight_cap of each map's current total for its k seeds (one pass of
// rsm_importance::map_weights's loop).
@compute @workgroup_size(64)
fn importance_cap(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let mi = thread_index(gid, groups);
    if (mi >= params.maps) {
        return;
    }
    let total = rows[info[mi].row_first + maps[mi].size - 1u];
    let k = max(info[mi].k, 1u);
    map_cap[mi] = max(total / k + select(0u, 1u, total % k != 0u), 1u);
}

// rsm_importance::warp: the texel (x, y) seed point i lands on in map mi, through the rows'
// running totals and the row's weights; (size, size) when the map has no importance.
fn warp(i: u32, mi: u32) -> vec2<u32> {
    let m = maps[mi];
    let first = info[mi].row_first;
    let n = m.size;
    let total = rows[first + n - 1u];
    if (total == 0u) {
        return vec2<u32>(n, n);
    }
    let f = halton_fractions(i);
    let target_row = scale_fraction(f.y, total);
    var lo = 0u;
    var hi = n;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (rows[first + mid] <= target_row) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let y = lo;
    var before = 0u;
    if (y > 0u) {
        before = rows[first + y - 1u];
    }
    let target_col = scale_fraction(f.x, rows[first + y] - before);
    let scale = quantum_scale(atomicLoad(&map_max[mi]), n * n);
    let cap = map_cap[mi];
    var acc = 0u;
    for (var x = 0u; x < n; x = x + 1u) {
        acc = acc + weight(m.first + y * n + x, scale, cap);
        if (acc > target_col) {
            return vec2<u32>(x, y);
        }
    }
    return vec2<u32>(n, n);
}

@compute @workgroup_size(64)
fn seed(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.k || live[j] != 0u) {
        return;
    }
    // The map of cluster j: the last whose clusters start at or before j (maps without
    // clusters share the next one's start and come before it).
    var lo = 0u;
    var hi = params.maps;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (info[mid].cluster_first <= j) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let mi = max(lo, 1u) - 1u;
    let mp = info[mi];
    let m = maps[mi];
    var h = vec2<u32>(m.size, m.size);
    if (params.importance != 0u) {
        h = warp(j - mp.cluster_first + 1u, mi);
    }
    if (h.x >= m.size) {
        h = halton_texel(j - mp.cluster_first + 1u, m.size);
    }
    var i = vpl_at_or_after(mp.vpl_start, mp.vpl_end, m.first + h.y * m.size + h.x);
    if (i >= mp.vpl_end) {
        i = mp.vpl_start;
    }
    let v = vpls[i];
    let t = texel_of(v, m);
    states[j] = ClusterState(v.position, t.x, v.normal, t.y, chroma(v.flux), mi);
}

fn cell_index(j: u32) -> u32 {
    let s = states[j];
    let mp = info[s.map];
    let c = cell_of(vec2<f32>(s.texel_x, s.texel_y), maps[s.map], mp.grid);
    return mp.cell_first + u32(c.y) * mp.grid + u32(c.x);
}

@compute @workgroup_size(64)
fn grid_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.k) {
        return;
    }
    atomicAdd(&counts[cell_index(j)], 1u);
}

// `counts` holds zeroed cursors here; the order inside a cell does not matter (assign takes the
// smallest (μ, index)).
@compute @workgroup_size(64)
fn grid_fill(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.k) {
        return;
    }
    let c = cell_index(j);
    items[offsets[c] + atomicAdd(&counts[c], 1u)] = j;
}

@compute @workgroup_size(64)
fn assign(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let mi = map_of_vpl(i);
    let mp = info[mi];
    let m = maps[mi];
    let v = vpls[i];
    let cp = chroma(v.flux);
    let c = cell_of(texel_of(v, m), m, mp.grid);
    let g = i32(mp.grid) - 1;
    let inf = bitcast<f32>(0x7f800000u);
    var best_mu = inf;
    var best = MISS;
    let r = i32(RSM_NEIGHBOURHOOD);
    for (var y = max(c.y - r, 0); y <= min(c.y + r, g); y = y + 1) {
        for (var x = max(c.x - r, 0); x <= min(c.x + r, g); x = x + 1) {
            let cell = mp.cell_first + u32(y) * mp.grid + u32(x);
            for (var t = offsets[cell]; t < offsets[cell + 1u]; t = t + 1u) {
                let j = items[t];
                let s = states[j];
                let d = mu((v.position - s.centre) * params.inv_extent, v.normal, s.normal, cp, s.chroma);
                if (d < best_mu || (d == best_mu && j < best)) {
                    best_mu = d;
                    best = j;
                }
            }
        }
    }
    if (best == MISS) {
        for (var j = mp.cluster_first; j < mp.cluster_first + mp.k; j = j + 1u) {
            let s = states[j];
            let d = mu((v.position - s.centre) * params.inv_extent, v.normal, s.normal, cp, s.chroma);
            if (d < best_mu || best == MISS) {
                best_mu = d;
                best = j;
            }
        }
    }
    labels[i] = best;
}

// Radix pass over bit `params.bit`: 1 where the label of the VPL at sorted position i has it
// clear (those go first, in order).
@compute @workgroup_size(64)
fn radix_flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    flags[i] = select(0u, 1u, ((labels[order[i]] >> params.bit) & 1u) == 0u);
}

@compute @workgroup_size(64)
fn radix_scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let zeros = offsets[i];
    var dst = zeros;
    if (flags[i] == 0u) {
        dst = offsets[params.n] + (i - zeros);
    }
    items[dst] = order[i];
}

// `ranges` zeroed before: empty clusters keep (0, 0).
@compute @workgroup_size(64)
fn cluster_ranges(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    let l = labels[order[i]];
    if (i == 0u || labels[order[i - 1u]] != l) {
        ranges[l].x = i;
    }
    if (i + 1u == params.n || labels[order[i + 1u]] != l) {
        ranges[l].y = i + 1u;
    }
}

// MapClusters::update for one cluster, over its members in sorted order, `params.chunk` of them
// per dispatch: lavapipe ends an invocation's loops after 65,535 iterations, and one cluster may
// hold all the VPLs. The sums run on across dispatches in `running`, so they stay the CPU's
// sequential float sums.
@compute @workgroup_size(64)
fn update(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.k) {
        return;
    }
    let r = ranges[j];
    let begin = r.x + params.first;
    if (r.y <= begin) {
        return;
    }
    let to = min(r.y, begin + params.chunk);
    var s = states[j];
    let m = maps[s.map];
    var weight = 0.0;
    var centre = vec3<f32>(0.0);
    var normal = vec3<f32>(0.0);
    var flux = vec3<f32>(0.0);
    var texel = vec2<f32>(0.0);
    if (params.first > 0u) {
        let a = running[3u * j];
        let b = running[3u * j + 1u];
        let c = running[3u * j + 2u];
        centre = a.xyz;
        weight = a.w;
        normal = b.xyz;
        flux = c.xyz;
        texel = vec2<f32>(b.w, c.w);
    }
    for (var t = begin; t < to; t = t + 1u) {
        let v = vpls[order[t]];
        let w = v.flux.x + v.flux.y + v.flux.z;
        weight = weight + w;
        centre = centre + v.position * w;
        normal = normal + v.normal * w;
        flux = flux + v.flux;
        texel = texel + texel_of(v, m);
    }
    if (to < r.y) {
        running[3u * j] = vec4<f32>(centre, weight);
        running[3u * j + 1u] = vec4<f32>(normal, texel.x);
        running[3u * j + 2u] = vec4<f32>(flux, texel.y);
        return;
    }
    if (weight > 0.0) {
        s.centre = centre / weight;
    }
    // glam's try_normalize: times the reciprocal length, if that is finite and positive.
    let rcp = 1.0 / length(normal);
    let inf = bitcast<f32>(0x7f800000u);
    if (rcp > 0.0 && rcp < inf) {
        s.normal = normal * rcp;
    }
    s.chroma = chroma(flux);
    let members = f32(r.y - r.x);
    s.texel_x = texel.x / members;
    s.texel_y = texel.y / members;
    states[j] = s;
}

// Each cluster's member nearest its centre, `params.chunk` members per dispatch like update, the
// nearest so far carried in `reps` and `running`.
@compute @workgroup_size(64)
fn representatives(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.k) {
        return;
    }
    let r = ranges[j];
    let begin = r.x + params.first;
    if (params.first > 0u && r.y <= begin) {
        return;
    }
    let to = min(r.y, begin + params.chunk);
    let c = states[j].centre;
    let inf = bitcast<f32>(0x7f800000u);
    var best_d = inf;
    var best = MISS;
    if (params.first > 0u) {
        best_d = running[3u * j].x;
        best = reps[j];
    }
    // Members in ascending VPL order: the first of equal distances is the lowest index.
    for (var t = begin; t < to; t = t + 1u) {
        let i = order[t];
        let d = dot(vpls[i].position - c, vpls[i].position - c);
        if (d < best_d) {
            best_d = d;
            best = i;
        }
    }
    reps[j] = best;
    running[3u * j].x = best_d;
    flags[j] = select(0u, 1u, r.y > r.x);
}

// The kept clusters renumbered by the scan of `flags`: their centroids and representatives in
// order, and every VPL's label.
@compute @workgroup_size(64)
fn compact_clusters(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.k) {
        return;
    }
    if (flags[j] == 1u) {
        let s = states[j];
        centroids[offsets[j]] = Endpoint(vec4<f32>(s.centre, 0.0), vec4<f32>(s.normal, 0.0));
        kept_reps[offsets[j]] = reps[j];
    }
}

@compute @workgroup_size(64)
fn compact_labels(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.n) {
        return;
    }
    labels[i] = offsets[labels[i]];
}
