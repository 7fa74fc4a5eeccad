// include: common/types.wgsl common/rng.wgsl common/bvh.wgsl common/surface.wgsl common/sampling.wgsl common/scene.wgsl common/bsdf.wgsl
// Stage bias_points: the bias compensation of the geometry-term clamp (vplgi-cpu/src/bias_points.rs).
// From each parent shading point, one segment sampled by its BSDF (by the cosine on a diffuse
// surface; stream (seed, STREAM_BIAS, i)) to the surface it sees; kept as a shading point seen
// from the parent where the clamp bites, with albedo = its albedo x the parent's x the sample's
// weight x the clamped share 1 - g_max / (a G), no emission and the parent's pixel. None where
// the segment meets a mirror or glass: no VPL sits there, so the clamp removed nothing.

struct Params {
    first: u32,   // first sample of this chunk
    count: u32,   // samples in this chunk
    seed: u32,    // the level's seed
    g_max: f32,
    eps: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(6) var<storage, read> parents: array<ShadingPoint>;
@group(0) @binding(7) var<storage, read_write> out: array<ShadingPoint>;

// bias_points::clamped_share: 1 - g_max / (a G) where the clamp bites, else 0.
fn clamped_share(p: vec3<f32>, np: vec3<f32>, y: vec3<f32>, ny: vec3<f32>, g_max: f32, lobe: f32) -> f32 {
    let g = unclamped_geometry_term(p, np, y, ny) * lobe;
    if (g > g_max) {
        return 1.0 - g_max / g;
    }
    return 0.0;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = thread_index(gid, groups);
    if (local >= params.count) {
        return;
    }
    let sp = parents[local];
    var child: ShadingPoint;
    child.pixel = sp.pixel;
    child.triangle = MISS;
    out[local] = child;
    if (sp.triangle == MISS) {
        return;
    }
    var rng = rng_new(params.seed, STREAM_BIAS, params.first + local);
    let bsdf = white_bsdf(sp.material);
    var dir: vec3<f32>;
    var weight = vec3<f32>(1.0);
    if (bsdf_is_glossy(bsdf)) {
        let u0 = rng_next_f32(&rng);
        let ux = rng_next_f32(&rng);
        let uy = rng_next_f32(&rng);
        let s = bsdf_sample_about(bsdf, sp.normal, sp.view, u0, vec2<f32>(ux, uy), true);
        if (s.valid == 0u) {
            return;
        }
        dir = s.wo;
        weight = s.weight;
    } else {
        let u1 = rng_next_f32(&rng);
        let u2 = rng_next_f32(&rng);
        dir = cosine_hemisphere(sp.normal, u1, u2);
    }
    var ng = scene_tri(sp.triangle).ng.xyz;
    if (dot(ng, sp.normal) < 0.0) {
        ng = -ng;
    }
    if (dot(dir, ng) <= 0.0) {
        return;
    }
    let inf = bitcast<f32>(0x7f800000u);
    let hit = bvh_trace(sp.position + ng * params.eps, dir, 0.0, inf, false);
    if (hit.triangle == NO_HIT) {
        return;
    }
    let surf = surface_at(hit, dir);
    if (bsdf_is_specular(surf.bsdf)) {
        return;
    }
    let w = clamped_share(sp.position, sp.normal, surf.position, surf.ns, params.g_max, bsdf_lobe(bsdf, sp.normal, sp.view, dir));
    if (w <= 0.0) {
        return;
    }
    child.position = surf.position;
    child.normal = surf.ns;
    child.triangle = hit.triangle;
    child.material = surf.material;
    child.albedo = surf.albedo * sp.albedo * weight * w;
    child.emitted = vec3<f32>(0.0);
    child.view = -dir;
    out[local] = child;
}
