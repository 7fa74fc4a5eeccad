// include: common/types.wgsl common/rng.wgsl common/metric.wgsl
// Stage 3's first step with --seeding adaptive, `seeding`: Wang et al.'s screen-space quadtree
// (the rules are vplgi_shared::seeding; the CPU twin is vplgi-cpu/src/seeding.rs). Three passes:
// node_sums level by level bottom up, node_variation once over the pixels, distribute level by
// level top down. Nodes of every level share one array, finest (level 1, 2 x 2 pixels) first.

struct Params {
    fix_min: vec4<f32>,     // fixed-point box of the hits (xyz)
    fix_ext: vec4<f32>,
    width: u32,             // image
    height: u32,
    spp: u32,               // hits of pixel p: offsets[p spp] .. offsets[(p + 1) spp]
    levels: u32,            // L: the root is level L
    level: u32,             // the level this dispatch works on
    side: u32,              // nodes per side at `level`
    level_first: u32,       // first node of `level`
    seed: u32,
    alpha: f32,             // alpha of Eq. 2 per unit length
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> points: array<Endpoint>;          // the hits
@group(0) @binding(2) var<storage, read> offsets: array<u32>;              // hits before each sample
@group(0) @binding(3) var<storage, read_write> counts: array<u32>;         // hits per node
@group(0) @binding(4) var<storage, read_write> sums: array<u32>;           // 6 (lo, hi) sums per node
@group(0) @binding(5) var<storage, read_write> variation: array<atomic<u32>>; // (lo, hi) per node
@group(0) @binding(6) var<storage, read_write> given: array<u32>;          // (seeds, first slot) per node
@group(0) @binding(7) var<storage, read_write> slots: array<u32>;          // K seed slots

// Quadtree::side and Quadtree::level_offset.
fn side_of(l: u32) -> u32 {
    return 1u << (params.levels - l);
}

fn level_offset(l: u32) -> u32 {
    var o = 0u;
    for (var m = 1u; m < l; m = m + 1u) {
        o = o + side_of(m) * side_of(m);
    }
    return o;
}

fn node_of(l: u32, x: u32, y: u32) -> u32 {
    return level_offset(l) + y * side_of(l) + x;
}

// The hits of pixel (x, y) as [first, end): none in the padding.
fn pixel_hits(x: u32, y: u32) -> vec2<u32> {
    if (x >= params.width || y >= params.height) {
        return vec2<u32>(0u);
    }
    let p = y * params.width + x;
    return vec2<u32>(offsets[p * params.spp], offsets[(p + 1u) * params.spp]);
}

// The child order of vplgi_shared::seeding::CHILDREN: (0, 0), (1, 0), (0, 1), (1, 1).
fn child(j: u32) -> vec2<u32> {
    return vec2<u32>(j & 1u, j >> 1u);
}

fn add64(a: vec2<u32>, v: vec2<u32>) -> vec2<u32> {
    let lo = a.x + v.x;
    return vec2<u32>(lo, a.y + v.y + select(0u, 1u, lo < a.x));
}

// ---- node_sums: counts and fixed-point sums of the nodes of one level, from the pixels
// (level 1) or from the four children.

@compute @workgroup_size(64)
fn node_sums(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.side * params.side) {
        return;
    }
    let x = i % params.side;
    let y = i / params.side;
    var s: array<vec2<u32>, 6>;
    for (var a = 0u; a < 6u; a = a + 1u) {
        s[a] = vec2<u32>(0u);
    }
    var n = 0u;
    for (var j = 0u; j < 4u; j = j + 1u) {
        let c = vec2<u32>(2u * x, 2u * y) + child(j);
        if (params.level == 1u) {
            let h = pixel_hits(c.x, c.y);
            for (var k = h.x; k < h.y; k = k + 1u) {
                let q = fix_position(points[k].position.xyz, params.fix_min.xyz, params.fix_ext.xyz);
                let m = fix_normal(points[k].normal.xyz);
                let v = array<u32, 6>(q.x, q.y, q.z, m.x, m.y, m.z);
                for (var a = 0u; a < 6u; a = a + 1u) {
                    s[a] = add64(s[a], vec2<u32>(v[a], 0u));
                }
                n = n + 1u;
            }
        } else {
            let cn = node_of(params.level - 1u, c.x, c.y);
            n = n + counts[cn];
            for (var a = 0u; a < 6u; a = a + 1u) {
                s[a] = add64(s[a], vec2<u32>(sums[cn * 12u + 2u * a], sums[cn * 12u + 2u * a + 1u]));
            }
        }
    }
    let node = params.level_first + i;
    counts[node] = n;
    for (var a = 0u; a < 6u; a = a + 1u) {
        sums[node * 12u + 2u * a] = s[a].x;
        sums[node * 12u + 2u * a + 1u] = s[a].y;
    }
}

// ---- node_variation: every hit's quantized Eq. 2 error against the mean of each node above
// it, added to that node (integer sums: the order of the atomics does not matter).

fn node_mean(node: u32) -> array<vec3<f32>, 2> {
    let n = counts[node];
    var m: array<f32, 6>;
    for (var a = 0u; a < 6u; a = a + 1u) {
        m[a] = mean64(sums[node * 12u + 2u * a], sums[node * 12u + 2u * a + 1u], n);
    }
    return array<vec3<f32>, 2>(
        fix_mean_position(vec3<f32>(m[0], m[1], m[2]), params.fix_min.xyz, params.fix_ext.xyz),
        fix_mean_normal(vec3<f32>(m[3], m[4], m[5])),
    );
}

// seeding::quantize_error: rounded to even, saturating.
fn quantize_error(e: f32) -> u32 {
    let r = round(e * ERROR_ONE);
    if (r >= 4294967296.0) {
        return 0xffffffffu;
    }
    return u32(r);
}

fn add_variation(node: u32, v: u32) {
    let old = atomicAdd(&variation[node * 2u], v);
    if (old > 0xffffffffu - v) {
        atomicAdd(&variation[node * 2u + 1u], 1u);
    }
}

@compute @workgroup_size(64)
fn node_variation(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = thread_index(gid, groups);
    if (p >= params.width * params.height) {
        return;
    }
    let x = p % params.width;
    let y = p / params.width;
    let h = pixel_hits(x, y);
    if (h.x == h.y) {
        return;
    }
    for (var l = 1u; l <= params.levels; l = l + 1u) {
        let node = node_of(l, x >> l, y >> l);
        let mean = node_mean(node);
        for (var k = h.x; k < h.y; k = k + 1u) {
            let pt = points[k];
            let e = ward_error(params.alpha, dist2(pt.position.xyz, mean[0]), cosine(pt.normal.xyz, mean[1]));
            add_variation(node, quantize_error(e));
        }
    }
}

// ---- distribute: each node of one level hands its seeds to its children, or picks hits.

// The hit of rank `rank` under node (l, x, y): children in CHILDREN order, then a pixel's hits.
fn hit_at(l0: u32, x0: u32, y0: u32, rank0: u32) -> u32 {
    var l = l0;
    var at = vec2<u32>(x0, y0);
    var rank = rank0;
    while (l > 1u) {
        var next = 2u * at;
        for (var j = 0u; j < 4u; j = j + 1u) {
            let c = 2u * at + child(j);
            let n = counts[node_of(l - 1u, c.x, c.y)];
            if (rank < n) {
                next = c;
                break;
            }
            rank = rank - n;
        }
        at = next;
        l = l - 1u;
    }
    for (var j = 0u; j < 4u; j = j + 1u) {
        let c = 2u * at + child(j);
        let h = pixel_hits(c.x, c.y);
        if (rank < h.y - h.x) {
            return h.x + rank;
        }
        rank = rank - (h.y - h.x);
    }
    return MISS;
}

fn variation_of(node: u32) -> vec2<u32> {
    return vec2<u32>(atomicLoad(&variation[node * 2u]), atomicLoad(&variation[node * 2u + 1u]));
}

// seeding::u64_f32.
fn u64_f32(v: vec2<u32>) -> f32 {
    return f32(v.y) * 4294967296.0 + f32(v.x);
}

// seeding::shares: floor(s c_j / W) - floor(s c_(j-1) / W) over cumulative weights, in f32.
fn shares(s: u32, w: array<vec2<u32>, 4>) -> array<u32, 4> {
    var out = array<u32, 4>(0u, 0u, 0u, 0u);
    var total = vec2<u32>(0u);
    for (var j = 0u; j < 4u; j = j + 1u) {
        total = add64(total, w[j]);
    }
    if (all(total == vec2<u32>(0u))) {
        return out;
    }
    let t = u64_f32(total);
    var cum = vec2<u32>(0u);
    var before = 0u;
    for (var j = 0u; j < 4u; j = j + 1u) {
        cum = add64(cum, w[j]);
        let upto = u32(floor(f32(s) * (u64_f32(cum) / t)));
        out[j] = upto - before;
        before = upto;
    }
    return out;
}

// seeding::capped_shares: children that reach their cap keep it, the rest is shared again.
fn capped_shares(s: u32, w: array<vec2<u32>, 4>, cap: array<u32, 4>) -> array<u32, 4> {
    var out = array<u32, 4>(0u, 0u, 0u, 0u);
    var full: array<bool, 4>;
    for (var j = 0u; j < 4u; j = j + 1u) {
        full[j] = cap[j] == 0u;
    }
    for (var round = 0u; round < 5u; round = round + 1u) {
        var left = s;
        var open: array<vec2<u32>, 4>;
        var any_open = false;
        for (var j = 0u; j < 4u; j = j + 1u) {
            if (full[j]) {
                left = left - out[j];
                open[j] = vec2<u32>(0u);
            } else {
                open[j] = w[j];
            }
            any_open = any_open || any(open[j] != vec2<u32>(0u));
        }
        if (!any_open) {
            for (var j = 0u; j < 4u; j = j + 1u) {
                open[j] = vec2<u32>(select(cap[j], 0u, full[j]), 0u);
            }
        }
        let sh = shares(left, open);
        var saturated = false;
        for (var j = 0u; j < 4u; j = j + 1u) {
            if (!full[j] && sh[j] >= cap[j]) {
                out[j] = cap[j];
                full[j] = true;
                saturated = true;
            }
        }
        if (!saturated) {
            for (var j = 0u; j < 4u; j = j + 1u) {
                if (!full[j]) {
                    out[j] = sh[j];
                }
            }
            break;
        }
    }
    return out;
}

@compute @workgroup_size(64)
fn distribute(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.side * params.side) {
        return;
    }
    let x = i % params.side;
    let y = i / params.side;
    let l = params.level;
    let node = params.level_first + i;
    let s = given[node * 2u];
    let first = given[node * 2u + 1u];
    let n = counts[node];
    if (s == 0u || n == 0u) {
        return;
    }
    if (s >= n && l == 1u) {
        for (var r = 0u; r < n; r = r + 1u) {
            slots[first + r] = hit_at(l, x, y, r);
        }
        return;
    }
    if (s >= n) {
        // Every hit is a seed: each child as many as it has hits, so that no invocation loops
        // over more than a 2 x 2 node's hits (lavapipe ends loops after 65,535 iterations).
        var at = first;
        for (var j = 0u; j < 4u; j = j + 1u) {
            let c = vec2<u32>(2u * x, 2u * y) + child(j);
            let cn = node_of(l - 1u, c.x, c.y);
            given[cn * 2u] = counts[cn];
            given[cn * 2u + 1u] = at;
            at = at + counts[cn];
        }
        return;
    }
    if (s == 1u || l == 1u) {
        // seeding::ranks: one hit in each of s strata of the n ranked hits.
        var rng = rng_new(params.seed, STREAM_SEEDING, node);
        let ratio = f32(n) / f32(s);
        for (var j = 0u; j < s; j = j + 1u) {
            let lo = u32(floor(f32(j) * ratio));
            var hi = n;
            if (j + 1u != s) {
                hi = u32(floor(f32(j + 1u) * ratio));
            }
            let len = max(select(0u, hi - lo, hi > lo), 1u);
            let r = lo + min(u32(rng_next_f32(&rng) * f32(len)), len - 1u);
            slots[first + j] = hit_at(l, x, y, r);
        }
        return;
    }
    // seeding::capped_shares over the children's variations, at most their hits each.
    var w: array<vec2<u32>, 4>;
    var cap: array<u32, 4>;
    for (var j = 0u; j < 4u; j = j + 1u) {
        let c = vec2<u32>(2u * x, 2u * y) + child(j);
        let cn = node_of(l - 1u, c.x, c.y);
        w[j] = variation_of(cn);
        cap[j] = counts[cn];
    }
    let sh = capped_shares(s, w, cap);
    var at = first;
    for (var j = 0u; j < 4u; j = j + 1u) {
        let c = vec2<u32>(2u * x, 2u * y) + child(j);
        let cn = node_of(l - 1u, c.x, c.y);
        given[cn * 2u] = sh[j];
        given[cn * 2u + 1u] = at;
        at = at + sh[j];
    }
}
