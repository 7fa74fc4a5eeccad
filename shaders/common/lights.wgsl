// Light tables (vplgi_scene::lights::LightSampler, uploaded by vplgi-gpu/src/lights.rs) and the
// sampling routines of the CPU twin, with the same draws in the same order. The tables
// ((cdf, realised pmf) pairs) are searched in the stages that bind them: `area_table` (emitters,
// by power) in shade.wgsl, `all_table` (emitters then punctual lights) in trace_vpls.wgsl.

fn uniform_triangle(u1: f32, u2: f32) -> vec2<f32> {
    let s = sqrt(u1);
    return vec2<f32>(s * (1.0 - u2), s * u2);
}

// light_groups::cos_bound: cos(max(theta - beta, 0)) from cos theta and (cos beta, sin beta).
fn cos_bound(cos_t: f32, cos_b: f32, sin_b: f32) -> f32 {
    if (cos_t >= cos_b) {
        return 1.0;
    }
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    return cos_t * cos_b + sin_t * sin_b;
}

// light_groups::group_importance: the group's power times upper bounds of both cosines over the
// distance squared to its centre; 0 when no point of the group can light p.
fn group_importance(g: LightGroup, p: vec3<f32>, n: vec3<f32>) -> f32 {
    let c = g.sphere.xyz;
    let r = g.sphere.w;
    let d = c - p;
    let d2 = dot(d, d);
    let r2 = r * r;
    if (d2 <= r2) {
        return g.power.x / max(r2, 1.17549435e-38);
    }
    let dist = sqrt(d2);
    let sin_s = r / dist;
    let cos_s = sqrt(max(1.0 - sin_s * sin_s, 0.0));
    let bound_p = cos_bound(dot(n, d) / dist, cos_s, sin_s);
    if (bound_p <= 0.0) {
        return 0.0;
    }
    var bound_l = 1.0;
    let cos_n = g.cone.w;
    if (cos_n > ANY_ORIENTATION) {
        let sin_n = sqrt(max(1.0 - cos_n * cos_n, 0.0));
        let cos_b = cos_n * cos_s - sin_n * sin_s;
        let sin_b = sin_n * cos_s + cos_n * sin_s;
        bound_l = cos_bound(-dot(g.cone.xyz, d) / dist, cos_b, sin_b);
        if (bound_l <= 0.0) {
            return 0.0;
        }
    }
    return g.power.x * bound_p * bound_l / d2;
}

// PunctualLight::falloff
fn punctual_falloff(l: Punctual, dir_from_light: vec3<f32>) -> f32 {
    return punctual_falloff_cos(l, dot(l.direction.xyz, dir_from_light));
}

// PunctualLight::falloff_cos
fn punctual_falloff_cos(l: Punctual, cos_axis: f32) -> f32 {
    if (l.position.w == PUNCTUAL_POINT) {
        return 1.0;
    }
    let cos_inner = l.direction.w;
    let cos_outer = l.intensity.w;
    let scale = 1.0 / max(cos_inner - cos_outer, 1e-3);
    let t = clamp((cos_axis - cos_outer) * scale, 0.0, 1.0);
    return t * t;
}

// lights::sun_origin: a uniform point on the disk of radius `radius` around `centre`
// perpendicular to the unit `axis`.
fn sun_origin(centre: vec3<f32>, axis: vec3<f32>, radius: f32, u1: f32, u2: f32) -> vec3<f32> {
    let r = radius * sqrt(u1);
    let phi = 2.0 * PI * u2;
    let basis = orthonormal_basis(axis);
    return centre + basis[0] * (r * cos(phi)) + basis[1] * (r * sin(phi));
}
