// include: common/types.wgsl common/rng.wgsl common/bvh.wgsl common/surface.wgsl common/sampling.wgsl common/lights.wgsl common/scene.wgsl common/bsdf.wgsl common/specular.wgsl
// Stage 1 with --vpl-source rsm, rsm_vpls (vplgi-cpu/src/rsm_vpls.rs): one reflective shadow map
// per light (vplgi_shared::rsm), in two kernels around scan.wgsl:
//   rsm_texel: one thread per texel: its ray (rsm::texel_ray) through at most specular_depth
//            mirrors and glass (reflect or refract by Fresnel, stream (seed, STREAM_RSM_SPECULAR,
//            t)), a VPL in slot t where it then hits and a count of 1, or a count of 0 where the
//            ray escapes or a spot sends nothing;
//   compact: the VPLs in texel order behind the exclusive offsets of the counts.

struct Params {
    texels: u32,
    maps: u32,
    eps: f32,
    seed: u32,
    specular_depth: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> maps: array<RsmLight>;
@group(0) @binding(11) var<storage, read_write> slots: array<Vpl>;
@group(0) @binding(12) var<storage, read_write> counts: array<u32>;
@group(0) @binding(13) var<storage, read_write> offsets: array<u32>;
@group(0) @binding(15) var<storage, read_write> vpls: array<Vpl>;

// rsm::map_of: the last map whose first texel is at or before t.
fn map_of(t: u32) -> u32 {
    var lo = 0u;
    var hi = params.maps;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (maps[mid].first <= t) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return max(lo, 1u) - 1u;
}

// rsm::r2_point
fn r2_point(k: u32) -> vec2<f32> {
    let x = k * 3242174889u + 2147483648u;
    let y = k * 2447445414u + 2147483648u;
    return vec2<f32>(f32(x >> 8u), f32(y >> 8u)) * (1.0 / 16777216.0);
}

// rsm::spot_falloff
fn spot_falloff(cos_axis: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let scale = 1.0 / max(cos_inner - cos_outer, 1e-3);
    let t = clamp((cos_axis - cos_outer) * scale, 0.0, 1.0);
    return t * t;
}

@compute @workgroup_size(64)
fn rsm_texel(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= params.texels) {
        return;
    }
    counts[t] = 0u;
    let m = maps[map_of(t)];
    let n = m.size;
    let k = t - m.first;
    let inv = 1.0 / f32(n);
    let u = (f32(k % n) + 0.5) * inv;
    let v = (f32(k / n) + 0.5) * inv;
    let texels = f32(n * n);
    var origin = m.origin;
    var dir: vec3<f32>;
    var power: vec3<f32>;
    if (m.kind == RSM_AREA) {
        let r = r2_point(k);
        let b = uniform_triangle(r.x, r.y);
        origin = m.origin + m.e1 * b.x + m.e2 * b.y + m.axis * params.eps;
        dir = cosine_hemisphere(m.axis, u, v);
        power = m.power / texels;
    } else if (m.kind == RSM_POINT) {
        dir = uniform_sphere(u, v);
        power = m.power / texels;
    } else if (m.kind == RSM_DIRECTIONAL) {
        let side = 2.0 * inv;
        origin = m.origin + m.e1 * (2.0 * u - 1.0) + m.e2 * (2.0 * v - 1.0);
        dir = m.axis;
        power = m.power * (side * side * dot(m.e1, m.e1));
    } else {
        let x = 2.0 * u - 1.0;
        let y = 2.0 * v - 1.0;
        let d = m.axis + m.e1 * x + m.e2 * y;
        let len2 = 1.0 + (x * x) * dot(m.e1, m.e1) + (y * y) * dot(m.e2, m.e2);
        let cos_t = 1.0 / sqrt(len2);
        let falloff = spot_falloff(cos_t, m.cos_inner, m.cos_outer);
        if (falloff <= 0.0) {
            return;
        }
        let side = 2.0 * inv;
        let omega = side * side * dot(m.e1, m.e1) * cos_t * cos_t * cos_t;
        dir = d * cos_t;
        power = m.power * (falloff * omega);
    }
    let inf = bitcast<f32>(0x7f800000u);
    var chain = rng_new(params.seed, STREAM_RSM_SPECULAR, t);
    var specular = 0u;
    loop {
        let hit = bvh_trace(origin, dir, 0.0, inf, false);
        if (hit.triangle == NO_HIT) {
            return;
        }
        let s = surface_at(hit, dir);
        if (specular == params.specular_depth || !bsdf_is_specular(s.bsdf)) {
            slots[t] = Vpl(s.position, t, s.ns, 1u, power * s.albedo, specular, -dir, s.material);
            counts[t] = 1u;
            return;
        }
        let out = scatter_specular(s, dir, rng_next_f32(&chain), false);
        if (out.valid == 0u) {
            return;
        }
        power = power * out.weight;
        specular = specular + 1u;
        dir = out.wo;
        origin = offset_toward(s.position, s.ng, s.position + dir, params.eps);
    }
}

@compute @workgroup_size(64)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= params.texels) {
        return;
    }
    if (counts[t] == 1u) {
        vpls[offsets[t]] = slots[t];
    }
}
