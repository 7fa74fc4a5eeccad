// Spherical harmonics of bands l = 0..3 and the glossy last bounce: the twin of
// vplgi-shared/src/sh.rs, operation for operation. Needs common/types.wgsl,
// common/sampling.wgsl and common/bsdf.wgsl.

// sh::basis: the 16 real basis functions at the unit direction d.
fn sh_basis(d: vec3<f32>) -> array<f32, SH_COEFFICIENTS> {
    let x = d.x;
    let y = d.y;
    let z = d.z;
    let x2 = x * x;
    let y2 = y * y;
    let z2 = z * z;
    return array<f32, SH_COEFFICIENTS>(
        SH_L0,
        SH_L1 * y,
        SH_L1 * z,
        SH_L1 * x,
        SH_L2_XY * (x * y),
        SH_L2_XY * (y * z),
        SH_L2_ZZ * (3.0 * z2 - 1.0),
        SH_L2_XY * (x * z),
        SH_L2_XX * (x2 - y2),
        SH_L3_XXY * (y * (3.0 * x2 - y2)),
        SH_L3_XYZ * (x * y * z),
        SH_L3_YZZ * (y * (5.0 * z2 - 1.0)),
        SH_L3_ZZZ * (z * (5.0 * z2 - 3.0)),
        SH_L3_YZZ * (x * (5.0 * z2 - 1.0)),
        SH_L3_ZXX * (z * (x2 - y2)),
        SH_L3_XXY * (x * (x2 - 3.0 * y2)),
    );
}

// sh::reconstruct: Σ_k g_k Y_k(d), clamped at 0 in each channel.
fn sh_reconstruct(sh: ptr<function, array<vec3<f32>, SH_COEFFICIENTS>>, d: vec3<f32>) -> vec3<f32> {
    let y = sh_basis(d);
    var g = vec3<f32>(0.0);
    for (var k = 0u; k < SH_COEFFICIENTS; k = k + 1u) {
        g = g + (*sh)[k] * y[k];
    }
    return max(g, vec3<f32>(0.0));
}

// sh::quadrature_point: point m of the Hammersley set.
fn sh_quadrature_point(m: u32) -> vec2<f32> {
    return vec2<f32>((f32(m) + 0.5) / f32(GLOSSY_DIRECTIONS), f32(reverseBits(m)) * (1.0 / 4294967296.0));
}

// sh::glossy_irradiance: what a receiver of white BSDF b takes in place of the irradiance.
fn sh_glossy_irradiance(sh: ptr<function, array<vec3<f32>, SH_COEFFICIENTS>>, irradiance: vec3<f32>, b: BsdfRecord, n: vec3<f32>, view: vec3<f32>) -> vec3<f32> {
    var metallic = 1.0;
    if (b.kind == BSDF_BLEND) {
        metallic = b.metallic;
    } else if (b.kind != BSDF_ROUGH_CONDUCTOR) {
        return irradiance;
    }
    var lobe = b;
    lobe.kind = BSDF_ROUGH_CONDUCTOR;
    lobe.reflectance = vec3<f32>(1.0);
    var q = vec3<f32>(0.0);
    for (var m = 0u; m < GLOSSY_DIRECTIONS; m = m + 1u) {
        let s = bsdf_sample_about(lobe, n, view, 0.0, sh_quadrature_point(m), true);
        if (s.valid == 0u) {
            continue;
        }
        let cos = dot(s.wo, n);
        if (cos > 0.0) {
            q = q + sh_reconstruct(sh, s.wo) * (s.weight.x / cos);
        }
    }
    return irradiance * (1.0 - metallic) + q * (metallic * PI / f32(GLOSSY_DIRECTIONS));
}
