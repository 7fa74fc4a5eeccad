// include: common/types.wgsl common/rng.wgsl common/bvh.wgsl common/surface.wgsl common/scene.wgsl common/sampling.wgsl common/bsdf.wgsl common/sh.wgsl
// Stage final_gather (vplgi-cpu/src/final_gather.rs): per sample point, gather_radius' rays
// (stream STREAM_GATHER, point j, counter 2r for ray r), each lit where it lands on a
// non-specular surface by the illumination cut: ρ_y Σ w_j E_j / Σ w_j over the cut nodes whose
// kernels reach y, w_j = K(|p_j − y| / r_j) max(0, n_j · n_y) (Eq. 4), K(u) = 1 − u² for u ≤ 1
// (Eq. 5). The walk of the tree above the cut is the CPU's: left child first, summing in the
// order it meets cut nodes, stopped after GATHER_VISITS; a hit no kernel reaches takes the same
// sum over kernels GATHER_FALLBACK_REACH times as wide (none: nothing), and is counted.
// A dispatch traces rays
// ray_first .. ray_end of every point and carries the sums; the last divides by the ray count:
// E = (1 / N) Σ ρ_y Ê(y), 1 / R = (1 / N) Σ 1 / t, and the spherical harmonics of the
// cosine-weighted incident light g = (1 / N) Σ ρ_y Ê(y) Y(ω) (vplgi-shared/src/sh.rs).

struct Params {
    count: u32,
    seed: u32,
    rays: u32,        // rays per point in all
    ray_first: u32,
    ray_end: u32,
    eps: f32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(6) var<storage, read> points: array<Endpoint>;
@group(0) @binding(7) var<storage, read_write> inv_radius: array<f32>;
@group(0) @binding(8) var<storage, read_write> irradiance: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> cut_nodes: array<CutNode>;
@group(0) @binding(10) var<storage, read> cut_bounds: array<CutBound>;
// The same boxes around the fallback's kernels, GATHER_FALLBACK_REACH times as wide.
@group(0) @binding(12) var<storage, read> wide_bounds: array<CutBound>;
// Per point: gather hits no kernel reached (lit by the wider kernels), and lookups stopped
// at the visit budget.
@group(0) @binding(11) var<storage, read_write> counts: array<vec2<u32>>;
// Per point: SH_COEFFICIENTS RGB coefficients, coefficient k's channel c at 3 k + c.
@group(0) @binding(13) var<storage, read_write> sh: array<f32>;

struct CutLight {
    sum: vec3<f32>,
    total: f32,
    truncated: bool,
}

// Eq. 5's kernel for u² (0 beyond u = 1).
fn kernel(u2: f32) -> f32 {
    if (u2 <= 1.0) {
        return 1.0 - u2;
    }
    return 0.0;
}

// final_gather::kernel_sum: Σ w E and Σ w over the cut nodes whose kernels, reach times their
// radius wide, reach y: through cut_bounds (reach 1) or wide_bounds (the fallback's reach).
fn kernel_sum(y: vec3<f32>, n: vec3<f32>, wide: bool) -> CutLight {
    var out = CutLight(vec3<f32>(0.0), 0.0, false);
    let reach = select(1.0, GATHER_FALLBACK_REACH, wide);
    let len = arrayLength(&cut_bounds);
    var stack: array<u32, PHOTON_STACK>;
    stack[0] = 0u;
    var top = 1u;
    var visits = 0u;
    while (top > 0u) {
        if (visits >= GATHER_VISITS) {
            out.truncated = true;
            break;
        }
        top = top - 1u;
        let i = stack[top];
        visits = visits + 1u;
        var b = cut_bounds[i];
        if (wide) {
            b = wide_bounds[i];
        }
        if (any(y < b.lo) || any(y > b.hi)) {
            continue;
        }
        if (b.slot == CUT_ABOVE) {
            if (2u * i + 1u < len) {
                stack[top] = 2u * i + 2u;
                stack[top + 1u] = 2u * i + 1u;
                top = top + 2u;
            }
            continue;
        }
        let node = cut_nodes[b.slot];
        let d = node.position - y;
        let r = node.radius * reach;
        let w = kernel((d.x * d.x + d.y * d.y + d.z * d.z) / (r * r)) * max(dot(node.normal, n), 0.0);
        if (w > 0.0) {
            out.sum = out.sum + w * node.irradiance;
            out.total = out.total + w;
        }
    }
    return out;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.count) {
        return;
    }
    let e = points[j];
    let n = e.normal.xyz;
    var rng = rng_new(params.seed, STREAM_GATHER, j);
    rng.counter = 2u * params.ray_first;
    let origin = e.position.xyz + n * params.eps;
    let inf = bitcast<f32>(0x7f800000u);
    let first = params.ray_first == 0u;
    var inv_sum = select(inv_radius[j], 0.0, first);
    var sum = select(irradiance[j].xyz, vec3<f32>(0.0), first);
    var c = select(counts[j], vec2<u32>(0u), first);
    var g: array<vec3<f32>, SH_COEFFICIENTS>;
    let base = j * 3u * SH_COEFFICIENTS;
    for (var k = 0u; k < SH_COEFFICIENTS; k = k + 1u) {
        let at = base + 3u * k;
        g[k] = select(vec3<f32>(sh[at], sh[at + 1u], sh[at + 2u]), vec3<f32>(0.0), first);
    }
    for (var r = params.ray_first; r < params.ray_end; r = r + 1u) {
        let u1 = rng_next_f32(&rng);
        let u2 = rng_next_f32(&rng);
        let dir = cosine_hemisphere(n, u1, u2);
        let hit = bvh_trace(origin, dir, params.eps, inf, false);
        if (hit.triangle == NO_HIT) {
            continue;
        }
        inv_sum = inv_sum + 1.0 / hit.t;
        let s = surface_at(hit, dir);
        if (bsdf_is_specular(s.bsdf)) {
            continue;
        }
        let l = kernel_sum(s.position, s.ns, false);
        var truncated = l.truncated;
        var e = vec3<f32>(0.0);
        if (l.total > 0.0) {
            e = l.sum / l.total;
        } else {
            c.x = c.x + 1u;
            let f = kernel_sum(s.position, s.ns, true);
            truncated = truncated || f.truncated;
            if (f.total > 0.0) {
                e = f.sum / f.total;
            }
        }
        c.y = c.y + select(0u, 1u, truncated);
        let light = s.albedo * e;
        sum = sum + light;
        let y = sh_basis(dir);
        for (var k = 0u; k < SH_COEFFICIENTS; k = k + 1u) {
            g[k] = g[k] + light * y[k];
        }
    }
    if (params.ray_end == params.rays) {
        let rays = f32(max(params.rays, 1u));
        inv_sum = inv_sum / rays;
        sum = sum / rays;
        for (var k = 0u; k < SH_COEFFICIENTS; k = k + 1u) {
            g[k] = g[k] / rays;
        }
    }
    for (var k = 0u; k < SH_COEFFICIENTS; k = k + 1u) {
        let at = base + 3u * k;
        sh[at] = g[k].x;
        sh[at + 1u] = g[k].y;
        sh[at + 2u] = g[k].z;
    }
    inv_radius[j] = inv_sum;
    irradiance[j] = vec4<f32>(sum, 0.0);
    counts[j] = c;
}
