// include: common/types.wgsl common/sampling.wgsl common/bsdf.wgsl common/sh.wgsl
// Stage interpolate (vplgi-cpu/src/interpolate.rs), --shade interpolate (Wang et al. 2009).
//
// `sample_points` turns the K sample points (the shading-point clusters' representatives) into
// shading points with rows 0 .. K, so that shade.wgsl's `shade_lights` sums the VPL lights at
// them, each with its own visibility row: the irradiance samples, bit for bit the sum a shading
// point of its own would get. `interpolate` then gives every shading point of a pixel range the
// irradiance-caching interpolation of its F clusters' samples, written where `shade_lights`
// would have written its light sum, for `shade_finish` to add emission and direct light. Where
// the samples carry spherical harmonics (--gi photon), a glossy shading point interpolates them
// with the same weights and writes sh_glossy_irradiance instead: the glossy last bounce.

struct Params {
    count: u32,         // sample_points: K; interpolate: shading points of the range
    first_sample: u32,  // interpolate: the range's first sample
    sp_first: u32,      // first sample held by the bound `sps` chunk
    f: u32,
    first_row: u32,     // first hit of the bound window of labels
    sh: u32,            // interpolate: 1 where the samples carry spherical harmonics
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(6) var<storage, read> points: array<Endpoint>;
@group(0) @binding(7) var<storage, read_write> sample_sps: array<ShadingPoint>;
@group(0) @binding(8) var<storage, read_write> sample_rows: array<u32>;
@group(0) @binding(9) var<storage, read> sps: array<ShadingPoint>;
@group(0) @binding(10) var<storage, read> row_of: array<u32>;
@group(0) @binding(11) var<storage, read> labels: array<u32>;
@group(0) @binding(12) var<storage, read> inv_radius: array<f32>;
@group(0) @binding(13) var<storage, read> irradiance: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read_write> running: array<vec4<f32>>;
// Per sample: SH_COEFFICIENTS RGB coefficients, coefficient k's channel c at 3 k + c.
@group(0) @binding(15) var<storage, read> sh: array<f32>;
// Each material's BSDF in white (shade.wgsl's lobes).
@group(0) @binding(16) var<storage, read> lobes: array<BsdfRecord>;

@compute @workgroup_size(64)
fn sample_points(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let j = thread_index(gid, groups);
    if (j >= params.count) {
        return;
    }
    var sp: ShadingPoint;
    sp.position = points[j].position.xyz;
    sp.normal = points[j].normal.xyz;
    sp.pixel = j;
    sp.triangle = 0u;
    // No material: an irradiance sample is shaded as a diffuse receiver (shade::lobe_record).
    sp.material = MISS;
    sample_sps[j] = sp;
    sample_rows[j] = j;
}

// interpolation::weight, operation for operation.
fn interpolation_weight(d2: f32, cos: f32, inv_r: f32) -> f32 {
    let error = sqrt(d2) * inv_r + sqrt(max(2.0 - 2.0 * cos, 0.0));
    return 1.0 / max(error, MIN_INTERPOLATION_ERROR);
}

@compute @workgroup_size(64)
fn interpolate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = thread_index(gid, groups);
    if (local >= params.count) {
        return;
    }
    let i = params.first_sample + local;
    let sp = sps[i - params.sp_first];
    if (sp.triangle == MISS) {
        running[local] = vec4<f32>(0.0);
        return;
    }
    let r = (row_of[i] - params.first_row) * params.f;
    // A material past the table (an irradiance sample's MISS) is diffuse, as in shade.wgsl.
    var receiver: BsdfRecord;
    if (sp.material < arrayLength(&lobes)) {
        receiver = lobes[sp.material];
    }
    let glossy = params.sh != 0u && sp.material < arrayLength(&lobes) && bsdf_is_glossy(receiver);
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    var g: array<vec3<f32>, SH_COEFFICIENTS>;
    for (var j = 0u; j < params.f; j = j + 1u) {
        let k = labels[r + j];
        if (k == MISS) {
            continue;
        }
        let s = points[k];
        let d = s.position.xyz - sp.position;
        let w = interpolation_weight(dot(d, d), dot(sp.normal, s.normal.xyz), inv_radius[k]);
        sum = sum + irradiance[k].xyz * w;
        total = total + w;
        if (glossy) {
            let base = k * 3u * SH_COEFFICIENTS;
            for (var c = 0u; c < SH_COEFFICIENTS; c = c + 1u) {
                let at = base + 3u * c;
                g[c] = g[c] + vec3<f32>(sh[at], sh[at + 1u], sh[at + 2u]) * w;
            }
        }
    }
    if (total <= 0.0) {
        running[local] = vec4<f32>(0.0);
        return;
    }
    var e = sum / total;
    if (glossy) {
        for (var c = 0u; c < SH_COEFFICIENTS; c = c + 1u) {
            g[c] = g[c] / total;
        }
        e = sh_glossy_irradiance(&g, e, receiver, sp.normal, sp.view);
    }
    running[local] = vec4<f32>(e, 0.0);
}
