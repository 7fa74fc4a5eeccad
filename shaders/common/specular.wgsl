// Where a ray leaves a surface (vplgi-cpu SurfaceHit::scatter). Needs
// common/types.wgsl, common/sampling.wgsl, common/bsdf.wgsl and common/surface.wgsl.

// The BSDF's sample for a ray that arrived along `dir`, u1 choosing reflection or refraction by
// Fresnel, its wo turned to world space; valid 0 where the surface sends nothing.
// `radiance`: a refraction's weight carries η².
fn scatter_specular(surf: Surface, dir: vec3<f32>, u1: f32, radiance: bool) -> BsdfSample {
    return scatter(surf, dir, u1, vec2<f32>(0.0), radiance);
}

// SurfaceHit::scatter: the BSDF's sample from u1 (which lobe) and u (where in it), wo in world
// space. +z is the side the normal points to: glass's outside.
fn scatter(surf: Surface, dir: vec3<f32>, u1: f32, u: vec2<f32>, radiance: bool) -> BsdfSample {
    var n = surf.ns;
    if (!surf.facing) {
        n = -surf.ns;
    }
    return bsdf_sample_about(surf.bsdf, n, -dir, u1, u, radiance);
}
