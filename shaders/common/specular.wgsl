// Where a ray leaves a mirror or glass (vplgi-cpu SurfaceHit::scatter_specular). Needs
// common/types.wgsl, common/sampling.wgsl, common/bsdf.wgsl and common/surface.wgsl.

// The BSDF's sample for a ray that arrived along `dir`, u1 choosing reflection or refraction by
// Fresnel, its wo turned to world space; valid 0 where the surface sends nothing. +z is the
// side the normal points to: glass's outside. `radiance`: a refraction's weight carries η².
fn scatter_specular(surf: Surface, dir: vec3<f32>, u1: f32, radiance: bool) -> BsdfSample {
    var n = surf.ns;
    if (!surf.facing) {
        n = -surf.ns;
    }
    let tb = orthonormal_basis(n);
    let wi = -dir;
    let local = vec3<f32>(dot(wi, tb[0]), dot(wi, tb[1]), dot(wi, n));
    var s = bsdf_sample(surf.bsdf, local, u1, vec2<f32>(0.0), radiance);
    s.wo = tb[0] * s.wo.x + tb[1] * s.wo.y + n * s.wo.z;
    return s;
}
