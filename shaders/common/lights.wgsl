// Light tables (vplgi_scene::lights::LightSampler, uploaded by vplgi-gpu/src/lights.rs) and the
// sampling routines of the CPU twin, with the same draws in the same order. The tables
// ((cdf, realised pmf) pairs) are searched in the stages that bind them: `area_table` (emitters,
// by power) in shade.wgsl, `all_table` (emitters then punctual lights) in trace_vpls.wgsl.

fn uniform_triangle(u1: f32, u2: f32) -> vec2<f32> {
    let s = sqrt(u1);
    return vec2<f32>(s * (1.0 - u2), s * u2);
}

// PunctualLight::falloff
fn punctual_falloff(l: Punctual, dir_from_light: vec3<f32>) -> f32 {
    return punctual_falloff_cos(l, dot(l.direction.xyz, dir_from_light));
}

// PunctualLight::falloff_cos
fn punctual_falloff_cos(l: Punctual, cos_axis: f32) -> f32 {
    if (l.position.w == 0.0) {
        return 1.0;
    }
    let cos_inner = l.direction.w;
    let cos_outer = l.intensity.w;
    let scale = 1.0 / max(cos_inner - cos_outer, 1e-3);
    let t = clamp((cos_axis - cos_outer) * scale, 0.0, 1.0);
    return t * t;
}
