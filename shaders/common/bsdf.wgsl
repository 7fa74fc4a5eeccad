// Surface scattering as Mitsuba 3 defines it: the twin of vplgi-shared/src/bsdf.rs, operation for
// operation. Local shading frame (normal +z); eval is the BSDF times |cos θ_o|; a sample's weight
// is eval / pdf of the lobe it came from. Needs common/types.wgsl (BsdfRecord) and
// common/sampling.wgsl.

struct BsdfSample {
    wo: vec3<f32>,
    pdf: f32,
    weight: vec3<f32>,
    // 1 for a delta lobe; 0 for a smooth one
    delta: u32,
    // 0 when the surface sends nothing
    valid: u32,
}

// (reflectance, cosine of the refracted direction signed to the side it leaves on, η_it, η_ti)
fn fresnel(cos_i: f32, eta: f32) -> vec4<f32> {
    let outside = cos_i >= 0.0;
    let eta_it = select(1.0 / eta, eta, outside);
    let eta_ti = select(eta, 1.0 / eta, outside);
    let cos_t2 = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    let ci = abs(cos_i);
    let ct = sqrt(max(cos_t2, 0.0));
    var r = 0.0;
    if (eta == 1.0) {
        r = 0.0;
    } else if (ci == 0.0) {
        r = 1.0;
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
        r = 0.5 * (a_s * a_s + a_p * a_p);
    }
    return vec4<f32>(r, select(ct, -ct, outside), eta_it, eta_ti);
}

fn ggx_d(m: vec3<f32>, alpha: f32) -> f32 {
    if (m.z <= 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    return 1.0 / (PI * a2 * t * t);
}

fn ggx_g1(v: vec3<f32>, m: vec3<f32>, alpha: f32) -> f32 {
    if (dot(v, m) * v.z <= 0.0) {
        return 0.0;
    }
    let xy2 = alpha * alpha * (v.x * v.x + v.y * v.y);
    if (xy2 == 0.0) {
        return 1.0;
    }
    return 2.0 / (1.0 + sqrt(1.0 + xy2 / (v.z * v.z)));
}

fn ggx_sample_visible(wi: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let vh = normalize(vec3<f32>(alpha * wi.x, alpha * wi.y, wi.z));
    let len2 = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if (len2 > 0.0) {
        t1 = vec3<f32>(-vh.y, vh.x, 0.0) / sqrt(len2);
    }
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    // φ in [-π, π): WGSL bounds the error of sin and cos only there.
    let phi = PI * (2.0 * u.y - 1.0);
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * (r * sin(phi));
    let nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    return normalize(vec3<f32>(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)));
}

fn bsdf_reflect(wi: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(-wi.x, -wi.y, wi.z);
}

// The twosided wrapper: a lobe seen from below is evaluated mirrored.
fn bsdf_mirrored(v: vec3<f32>, below: bool) -> vec3<f32> {
    return select(v, vec3<f32>(v.x, v.y, -v.z), below);
}

fn diffuse_eval(reflectance: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    return reflectance * wo.z / PI;
}

fn diffuse_pdf(wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return 0.0;
    }
    return wo.z / PI;
}

fn rough_eval(reflectance: vec3<f32>, alpha: f32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    let m = normalize(wi + wo);
    let g = ggx_g1(wi, m, alpha) * ggx_g1(wo, m, alpha);
    return reflectance * (ggx_d(m, alpha) * g / (4.0 * wi.z));
}

fn rough_pdf(alpha: f32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return 0.0;
    }
    let m = normalize(wi + wo);
    if (dot(wi, m) <= 0.0 || dot(wo, m) <= 0.0) {
        return 0.0;
    }
    return ggx_d(m, alpha) * ggx_g1(wi, m, alpha) / (4.0 * wi.z);
}

fn no_sample() -> BsdfSample {
    return BsdfSample(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0u, 0u);
}

fn diffuse_sample(reflectance: vec3<f32>, wi: vec3<f32>, u: vec2<f32>) -> BsdfSample {
    if (wi.z <= 0.0) {
        return no_sample();
    }
    let wo = cosine_hemisphere(vec3<f32>(0.0, 0.0, 1.0), u.x, u.y);
    return BsdfSample(wo, wo.z / PI, reflectance, 0u, select(0u, 1u, wo.z > 0.0));
}

fn rough_sample(reflectance: vec3<f32>, alpha: f32, wi: vec3<f32>, u: vec2<f32>) -> BsdfSample {
    if (wi.z <= 0.0) {
        return no_sample();
    }
    let m = ggx_sample_visible(wi, alpha, u);
    let wo = 2.0 * dot(wi, m) * m - wi;
    if (wo.z <= 0.0) {
        return no_sample();
    }
    let pdf = rough_pdf(alpha, wi, wo);
    return BsdfSample(wo, pdf, reflectance * ggx_g1(wo, m, alpha), 0u, select(0u, 1u, pdf > 0.0));
}

fn bsdf_eval(b: BsdfRecord, wi_: vec3<f32>, wo_: vec3<f32>) -> vec3<f32> {
    let below = wi_.z < 0.0;
    let wi = bsdf_mirrored(wi_, below);
    let wo = bsdf_mirrored(wo_, below);
    switch b.kind {
        case BSDF_DIFFUSE: {
            return diffuse_eval(b.reflectance, wi, wo);
        }
        case BSDF_ROUGH_CONDUCTOR: {
            return rough_eval(b.reflectance, b.alpha, wi, wo);
        }
        case BSDF_BLEND: {
            return (1.0 - b.metallic) * diffuse_eval(b.reflectance, wi, wo)
                + b.metallic * rough_eval(b.reflectance, b.alpha, wi, wo);
        }
        default: {
            return vec3<f32>(0.0);
        }
    }
}

fn bsdf_pdf(b: BsdfRecord, wi_: vec3<f32>, wo_: vec3<f32>) -> f32 {
    let below = wi_.z < 0.0;
    let wi = bsdf_mirrored(wi_, below);
    let wo = bsdf_mirrored(wo_, below);
    switch b.kind {
        case BSDF_DIFFUSE: {
            return diffuse_pdf(wi, wo);
        }
        case BSDF_ROUGH_CONDUCTOR: {
            return rough_pdf(b.alpha, wi, wo);
        }
        case BSDF_BLEND: {
            return (1.0 - b.metallic) * diffuse_pdf(wi, wo) + b.metallic * rough_pdf(b.alpha, wi, wo);
        }
        default: {
            return 0.0;
        }
    }
}

// A thin slab's (reflectance, transmittance), its internal reflections summed.
fn thin_reflectance(cos_i: f32, eta: f32) -> vec2<f32> {
    var r = fresnel(abs(cos_i), eta).x;
    let t = 1.0 - r;
    if (r < 1.0) {
        r = r + t * t * r / (1.0 - r * r);
    }
    return vec2<f32>(r, 1.0 - r);
}

// `radiance`: a refracted ray's weight carries η_ti² (camera paths); not for light paths.
fn bsdf_sample(b: BsdfRecord, wi: vec3<f32>, u1: f32, u: vec2<f32>, radiance: bool) -> BsdfSample {
    let below = wi.z < 0.0;
    let up = bsdf_mirrored(wi, below);
    var s = no_sample();
    switch b.kind {
        case BSDF_DIFFUSE: {
            s = diffuse_sample(b.reflectance, up, u);
            s.wo = bsdf_mirrored(s.wo, below);
        }
        case BSDF_ROUGH_CONDUCTOR: {
            s = rough_sample(b.reflectance, b.alpha, up, u);
            s.wo = bsdf_mirrored(s.wo, below);
        }
        case BSDF_BLEND: {
            if (u1 <= b.metallic) {
                s = rough_sample(b.reflectance, b.alpha, up, u);
            } else {
                s = diffuse_sample(b.reflectance, up, u);
            }
            s.wo = bsdf_mirrored(s.wo, below);
        }
        case BSDF_MIRROR: {
            if (wi.z != 0.0) {
                s = BsdfSample(bsdf_reflect(wi), 1.0, b.reflectance, 1u, 1u);
            }
        }
        case BSDF_DIELECTRIC: {
            let f = fresnel(wi.z, b.eta);
            if (u1 <= f.x) {
                s = BsdfSample(bsdf_reflect(wi), f.x, vec3<f32>(1.0), 1u, 1u);
            } else {
                let wo = vec3<f32>(-f.w * wi.x, -f.w * wi.y, f.y);
                let scale = select(1.0, f.w * f.w, radiance);
                s = BsdfSample(wo, 1.0 - f.x, vec3<f32>(scale), 1u, 1u);
            }
        }
        case BSDF_THIN_DIELECTRIC: {
            let rt = thin_reflectance(wi.z, b.eta);
            if (u1 <= rt.x) {
                s = BsdfSample(bsdf_reflect(wi), rt.x, vec3<f32>(1.0), 1u, 1u);
            } else {
                s = BsdfSample(-wi, rt.y, vec3<f32>(1.0), 1u, 1u);
            }
        }
        default: {}
    }
    return s;
}

// Bsdf::sample_about: bsdf_sample with wi and the sampled wo in world space, +z the unit normal n.
fn bsdf_sample_about(b: BsdfRecord, n: vec3<f32>, wi: vec3<f32>, u1: f32, u: vec2<f32>, radiance: bool) -> BsdfSample {
    let tb = orthonormal_basis(n);
    let local = vec3<f32>(dot(wi, tb[0]), dot(wi, tb[1]), dot(wi, n));
    var s = bsdf_sample(b, local, u1, u, radiance);
    s.wo = tb[0] * s.wo.x + tb[1] * s.wo.y + n * s.wo.z;
    return s;
}

// Every lobe a delta (Bsdf::is_specular): seen only along mirror and refraction directions.
fn bsdf_is_specular(b: BsdfRecord) -> bool {
    return b.kind == BSDF_MIRROR || b.kind == BSDF_DIELECTRIC || b.kind == BSDF_THIN_DIELECTRIC;
}

// Surface::is_glossy: rough metal, alone or blended.
fn bsdf_is_glossy(b: BsdfRecord) -> bool {
    return b.kind == BSDF_ROUGH_CONDUCTOR || b.kind == BSDF_BLEND;
}

// Surface::lobe: a white surface of this kind's BSDF from wi to wo (unit world directions about
// the shading normal n) over a white Lambertian surface's 1 / π; exactly 1 for a diffuse one.
fn bsdf_lobe(b: BsdfRecord, n: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if (b.kind == BSDF_DIFFUSE) {
        return 1.0;
    }
    var white = b;
    white.reflectance = vec3<f32>(1.0);
    let tb = orthonormal_basis(n);
    let li = vec3<f32>(dot(wi, tb[0]), dot(wi, tb[1]), dot(wi, n));
    let lo = vec3<f32>(dot(wo, tb[0]), dot(wo, tb[1]), dot(wo, n));
    if (lo.z == 0.0) {
        return 0.0;
    }
    return PI * bsdf_eval(white, li, lo).x / abs(lo.z);
}
