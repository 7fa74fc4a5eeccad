//! Closed-form answers the CPU reference must reproduce.

use glam::Vec3;
use std::f32::consts::PI;
use vplgi_cpu::shade::{indirect, LightArrays, VisibilitySource, VplLight};
use vplgi_cpu::visibility::BitMatrix;
use vplgi_cpu::{CpuScene, NoProgress};
use vplgi_scene::cornell::plane_with_point_light;
use vplgi_types::{ClusterMode, FrameConfig, ShadingPoint, TraceParams};

/// A 32x32 frame of `scene` lit by direct light alone (no VPLs) on the CPU: its configuration,
/// shading points and pixels.
fn direct_light_frame(
    scene: &vplgi_scene::Scene,
) -> (FrameConfig, Vec<ShadingPoint>, Vec<[f32; 3]>) {
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(scene, &device).unwrap();
    let cfg = FrameConfig {
        width: 32,
        height: 32,
        vpls: 0,
        cluster: ClusterMode::None,
        ..FrameConfig::reference()
    };
    let sps = vplgi_cpu::shading_points::shading_points(&cs, &cfg.camera_params(cs.scene.camera));
    let pixels = vplgi_cpu::render(&cs, &cfg, &NoProgress).unwrap().pixels;
    (cfg, sps, pixels)
}

/// A point light of intensity I at height h over a Lambertian plane of albedo ρ: the radiance at
/// horizontal distance r is ρ/π · I h / (h² + r²)^{3/2}. With no VPLs the image is exactly that
/// (up to f32 rounding): checks shading points, direct light and the camera together.
#[test]
fn point_light_over_a_plane_matches_the_closed_form() {
    let (h, rho, intensity) = (1.5f32, 0.6f32, 4.0f32);
    let scene = plane_with_point_light(2.0, h, rho, intensity);
    let (_, sps, pixels) = direct_light_frame(&scene);
    let mut checked = 0;
    let mut worst = 0.0f32;
    for (sp, px) in sps.iter().zip(&pixels) {
        if sp.is_miss() {
            assert_eq!(*px, [0.0; 3]);
            continue;
        }
        let p = Vec3::from(sp.position);
        let r2 = p.x * p.x + p.z * p.z;
        let expected = rho / PI * intensity * h / (h * h + r2).powf(1.5);
        let rel = (px[0] - expected).abs() / expected;
        worst = worst.max(rel);
        checked += 1;
    }
    println!("point light over a plane: {checked} pixels, worst relative error {worst:.2e}");
    assert!(checked > 500, "the plane must fill most of the image");
    assert!(worst < 1e-4, "worst relative error {worst}");
}

/// One VPL of flux Φ at height h above a plane, facing down: the indirect radiance at horizontal
/// distance r is Φ · (ρ/π) · cos θ_p cos θ_v / (π d²) with cos θ_p = cos θ_v = h/d (Eq. 6 with a
/// Lambertian VPL), below the clamp; above it, G is capped at 1/d_min².
#[test]
fn one_vpl_over_a_plane_matches_the_closed_form() {
    let (h, rho) = (0.8f32, 0.5f32);
    let flux = Vec3::new(2.0, 1.0, 0.5);
    let light = VplLight::new(Vec3::new(0.0, h, 0.0), -Vec3::Y, flux);
    let mut matrix = BitMatrix::new(1, 1);
    matrix.set(0, 0);
    let row_of = [0u32];
    let vis = VisibilitySource::Own { matrix: &matrix, row_of: &row_of, first_row: 0 };
    for r in [0.0f32, 0.3, 1.0, 2.5] {
        let sp = ShadingPoint {
            position: [r, 0.0, 0.0],
            normal: [0.0, 1.0, 0.0],
            albedo: [rho; 3],
            ..Default::default()
        };
        let d2 = h * h + r * r;
        let g = (h * h / d2) / d2;
        let expected = flux * (rho / PI) * g / PI;
        let got =
            indirect(&[], &sp, 0, &LightArrays::new(&vec![light].into(), &[]), &vis, f32::INFINITY);
        assert!(
            (got - expected).abs().max_element() <= 1e-6 * expected.max_element(),
            "r = {r}: {got} vs {expected}"
        );
        // With the clamp at d_min = h the geometry term at r = 0 is exactly 1/h², i.e. unclamped;
        // at d_min = 2h it is capped at 1/(4h²).
        let capped = indirect(
            &[],
            &sp,
            0,
            &LightArrays::new(&vec![light].into(), &[]),
            &vis,
            1.0 / (4.0 * h * h),
        );
        let expected_capped = flux * (rho / PI) * g.min(1.0 / (4.0 * h * h)) / PI;
        assert!((capped - expected_capped).abs().max_element() <= 1e-6 * expected.max_element());
    }
    // Invisible: nothing.
    let blocked = BitMatrix::new(1, 1);
    let sp = ShadingPoint { normal: [0.0, 1.0, 0.0], albedo: [rho; 3], ..Default::default() };
    let vis = VisibilitySource::Own { matrix: &blocked, row_of: &row_of, first_row: 0 };
    assert_eq!(
        indirect(&[], &sp, 0, &LightArrays::new(&vec![light].into(), &[]), &vis, f32::INFINITY),
        Vec3::ZERO
    );
}

/// Light particles from a point light over a square: the fraction of the light's power that
/// reaches the square is its solid angle over 4π, Ω = 4 atan(a² / (h √(2a² + h²))), so with one
/// bounce the VPLs' total flux is ρ I Ω. The estimate's relative standard deviation is
/// √((1 − Ω/4π) / N) for N VPLs; the test allows 4 of them.
#[test]
fn vpl_flux_from_a_point_light_matches_the_solid_angle() {
    let (a, h, rho, intensity) = (1.0f32, 0.7f32, 0.5f32, 3.0f32);
    let scene = plane_with_point_light(a, h, rho, intensity);
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let n = 40_000;
    let set = vplgi_cpu::trace_vpls::trace_vpls(&cs, &TraceParams::new(7, n, 1), &NoProgress);
    assert_eq!(set.vpls.len(), n as usize);
    let total: f64 = set.vpls.iter().map(|v| v.flux[0] as f64).sum();
    let omega = 4.0 * ((a * a) as f64 / (h as f64 * ((2.0 * a * a + h * h) as f64).sqrt())).atan();
    let expected = (rho * intensity) as f64 * omega;
    let p = omega / (4.0 * std::f64::consts::PI);
    let sigma = ((1.0 - p) / n as f64).sqrt();
    let rel = (total - expected) / expected;
    println!(
        "VPL flux {total:.5} vs ρIΩ = {expected:.5}: {:+.2} σ (σ = {:.2e} relative)",
        rel / sigma,
        sigma
    );
    assert!(rel.abs() < 4.0 * sigma);
    // Every VPL lies on the plane, faces up and came from one bounce.
    assert!(set
        .vpls
        .iter()
        .all(|v| v.position[1].abs() < 1e-5 && v.normal == [0.0, 1.0, 0.0] && v.bounce == 1));
}

/// The sun (a directional light of irradiance E travelling at θ from the plane's normal) over a
/// Lambertian plane of albedo ρ: every point the sun reaches has radiance ρ/π · E cos θ, on both
/// backends. A cube on the plane casts a shadow of direct light only (no VPLs): black.
#[test]
fn sun_over_a_plane_matches_the_closed_form_on_both_backends() {
    let scene = vplgi_tests::inputs::sunlit_plane_with_box();
    let vplgi_scene::PunctualLight::Directional { direction, irradiance } = scene.lights[0] else {
        unreachable!()
    };
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let cfg = FrameConfig {
        width: 48,
        height: 48,
        vpls: 0,
        cluster: ClusterMode::None,
        ..FrameConfig::reference()
    };
    let sps = vplgi_cpu::shading_points::shading_points(&cs, &cfg.camera_params(cs.scene.camera));
    let cpu = vplgi_cpu::render(&cs, &cfg, &NoProgress).unwrap().pixels;
    let gpu =
        vplgi_tests::gpu("sun_over_a_plane_matches_the_closed_form_on_both_backends").map(|ctx| {
            let kernels = vplgi_gpu::GpuKernels::new(&ctx.device).unwrap();
            vplgi_gpu::render(&ctx.device, &ctx.queue, &kernels, &scene, &cfg).unwrap().pixels
        });
    let cos = -direction.y;
    for (backend, pixels) in [("CPU", Some(&cpu)), ("GPU", gpu.as_ref())] {
        let Some(pixels) = pixels else { continue };
        let (mut worst, mut lit, mut shadowed) = (0.0f32, 0, 0);
        for (sp, px) in sps.iter().zip(pixels) {
            let p = Vec3::from(sp.position);
            // Plane points outside the cube's footprint, the cube's top, and shadowed plane points.
            if sp.is_miss() || p.y.abs() > 1e-4 {
                continue;
            }
            // Whether the ray back towards the sun crosses the cube grown (or shrunk) by m: a
            // slab test. Points within 0.01 of the shadow's edge may fall either side by rounding.
            let crosses = |m: f32| {
                let (lo, hi) = (Vec3::new(-0.3, 0.0, -0.3) - m, Vec3::new(0.2, 0.5, 0.2) + m);
                let back = -direction;
                let (mut near, mut far) = (0.0f32, f32::INFINITY);
                for a in 0..3 {
                    let (t0, t1) = ((lo[a] - p[a]) / back[a], (hi[a] - p[a]) / back[a]);
                    near = near.max(t0.min(t1));
                    far = far.min(t0.max(t1));
                }
                near <= far
            };
            let expected = Vec3::from(sp.albedo) / PI * irradiance * cos;
            let got = Vec3::from(*px);
            if crosses(-0.01) {
                assert_eq!(got, Vec3::ZERO, "{backend}: shadowed point {p} is lit");
                shadowed += 1;
                continue;
            }
            if crosses(0.01) {
                continue;
            }
            let rel = ((got - expected).abs() / expected).max_element();
            worst = worst.max(rel);
            lit += 1;
        }
        println!("{backend}: sun over a plane: {lit} lit pixels, worst relative error {worst:.2e}; {shadowed} shadowed pixels black");
        assert!(worst < 1e-4, "{backend}: worst relative error {worst}");
        assert!(
            lit > 500 && shadowed > 20,
            "the image must show lit plane and shadow ({lit}, {shadowed})"
        );
    }
}

/// Light particles from the sun over a plane with a cube: the particles' disk sends E π R², of
/// which what crosses the plane's and the cube's top's projections lands, so with one bounce the
/// VPLs' total flux is E cos θ Σ ρ_i A_i over the lit surfaces seen along the light (the plane
/// outside the cube's shadow, the cube's top and its two sunlit walls, each at its own cosine).
/// The particles start from a scrambled Sobol' set over the disk, so the hit count is far closer
/// than a binomial draw's σ (4.3e-3 here; measured 1.5e-4): the test allows 2e-3, which a
/// missing wall (2 %) or cosine would exceed. The same holds for the shadow map's VPLs, whose
/// texels round those areas.
#[test]
fn vpl_flux_from_the_sun_is_its_irradiance_on_the_lit_surfaces() {
    let scene = vplgi_tests::inputs::sunlit_plane_with_box();
    let vplgi_scene::PunctualLight::Directional { direction, irradiance } = scene.lights[0] else {
        unreachable!()
    };
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    // The flux reaching each surface, E cos A, summed with its albedo: the floor's shadow is the
    // cube's projection along the sun, the area the cube's top and walls take from the floor.
    let (plane_rho, box_rho) = (0.6f64, Vec3::new(0.7, 0.4, 0.3).as_dvec3());
    let d = direction.as_dvec3();
    let side = 0.5f64;
    // Cross-section the cube presents to the sun: top |d_y| + walls |d_x| + |d_z|, each side².
    let (top, wall_x, wall_z) =
        (side * side * -d.y, side * side * d.x.abs(), side * side * d.z.abs());
    let plane_lit = (4.0 * -d.y) - (top + wall_x + wall_z);
    let e = irradiance.as_dvec3();
    let expected = e * plane_rho * plane_lit + e * box_rho * (top + wall_x + wall_z);
    let sun = vplgi_scene::lights::SunFrame::of(&scene);
    let n = 60_000;
    let set = vplgi_cpu::trace_vpls::trace_vpls(&cs, &TraceParams::new(9, n, 1), &NoProgress);
    let total = set.vpls.iter().fold(glam::DVec3::ZERO, |a, v| a + Vec3::from(v.flux).as_dvec3());
    let p = (4.0 * -d.y) / (std::f64::consts::PI * (sun.radius as f64).powi(2));
    let sigma = ((1.0 - p) / (n as f64 * p)).sqrt();
    let rel = (total - expected) / expected;
    println!("sun VPL flux {total:.5} vs E cos A ρ = {expected:.5}: relative {:+.2e} {:+.2e} {:+.2e} (binomial σ {sigma:.2e})", rel.x, rel.y, rel.z);
    assert!(rel.abs().max_element() < 2e-3, "{rel}");
    assert!(set.vpls.iter().all(|v| v.bounce == 1));
    // The shadow map: one orthographic map, its texels' flux summed the same way.
    let rsm =
        vplgi_cpu::rsm_vpls::rsm_vpls(&cs, &vplgi_types::RsmParams::new(256, 1), &NoProgress).vpls;
    let total = rsm.iter().fold(glam::DVec3::ZERO, |a, v| a + Vec3::from(v.flux).as_dvec3());
    let rel = (total - expected) / expected;
    println!(
        "sun shadow-map VPL flux {total:.5}: relative {:+.2e} {:+.2e} {:+.2e}",
        rel.x, rel.y, rel.z
    );
    assert!(rel.abs().max_element() < 2e-3, "{rel}");
}

/// A lone emissive square seen against the background through jittered samples: each pixel's
/// mean is the radiance times the part of the pixel the square covers (its image is an
/// axis-aligned rectangle on the film, edges at fractional pixels), on both backends. Samples
/// whose own ray misses carry the emission the rest of their pixel sees: dropping it would make
/// edge pixels dark by about their uncovered share. Each sample's emission comes from 4 x 4
/// stratified rays, so it is a multiple of 1/16 of the radiance, and across an edge pixel's
/// samples it spreads far less than one ray's all-or-nothing (checked on both backends' shading
/// points).
#[test]
fn emission_through_jittered_pixels_is_the_covered_area_on_both_backends() {
    use vplgi_types::params::EMISSION_STRATA;
    let (half, le) = (1.0f32, 2.0f32);
    let scene = vplgi_tests::inputs::emissive_square(half, Vec3::splat(le));
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let cfg = FrameConfig {
        width: 16,
        height: 16,
        spp: 64,
        vpls: 0,
        cluster: ClusterMode::None,
        ..FrameConfig::reference()
    };
    let (w, h) = (cfg.width as f32, cfg.height as f32);
    // The square at distance 5 spans tangents +-half / 5 of tan(yfov / 2) on the film (aspect 1).
    let reach = half / (scene.camera.position.z * (0.5 * scene.camera.yfov).tan());
    let (x0, x1, y0, y1) = (
        0.5 * w * (1.0 - reach),
        0.5 * w * (1.0 + reach),
        0.5 * h * (1.0 - reach),
        0.5 * h * (1.0 + reach),
    );
    let overlap = |a: f32, b: f32, lo: f32, hi: f32| (b.min(hi) - a.max(lo)).max(0.0);
    let covered = |px: u32| {
        let (i, j) = ((px % cfg.width) as f32, (px / cfg.width) as f32);
        overlap(i, i + 1.0, x0, x1) * overlap(j, j + 1.0, y0, y1)
    };
    let ctx =
        vplgi_tests::gpu("emission_through_jittered_pixels_is_the_covered_area_on_both_backends");
    let cpu = vplgi_cpu::render(&cs, &cfg, &NoProgress).unwrap().pixels;
    let gpu = ctx.as_ref().map(|ctx| {
        let kernels = vplgi_gpu::GpuKernels::new(&ctx.device).unwrap();
        vplgi_gpu::render(&ctx.device, &ctx.queue, &kernels, &scene, &cfg).unwrap().pixels
    });
    for (backend, pixels) in [("CPU", Some(&cpu)), ("GPU", gpu.as_ref())] {
        let Some(pixels) = pixels else { continue };
        let (mut worst, mut edges) = (0.0f32, 0);
        for (px, got) in pixels.iter().enumerate() {
            let expected = le * covered(px as u32);
            worst = worst.max((got[0] - expected).abs() / le);
            edges += (expected > 0.0 && expected < le) as u32;
        }
        println!("{backend}: emissive square, {edges} edge pixels: worst |mean - L covered| = {worst:.4} L");
        // 64 samples of at most 7 partly covered strata each: sigma <= sqrt(7 / 4) / 16 / 8 = 0.010 L.
        assert!(worst < 0.05, "{backend}: a pixel's emission is {worst} L from the covered area");
        assert!(edges >= 30, "the square's edges must cross pixels ({edges})");
    }
    let camera = cfg.camera_params(scene.camera);
    let cpu_sps =
        vplgi_cpu::shading_points::shading_points(&cs, &cfg.camera_params(cs.scene.camera));
    let gpu_sps = ctx.as_ref().map(|ctx| {
        let gs = vplgi_gpu::scene::GpuScene::new(&ctx.device, &scene).unwrap();
        let kernel = vplgi_gpu::shading_points::ShadingPointsKernel::new(&ctx.device).unwrap();
        kernel.run(&ctx.device, &ctx.queue, &gs, &camera, None).unwrap()
    });
    let strata = (EMISSION_STRATA * EMISSION_STRATA) as f32;
    for (backend, sps) in [("CPU", Some(&cpu_sps)), ("GPU", gpu_sps.as_ref())] {
        let Some(sps) = sps else { continue };
        let mut worst_spread = 0.0f32;
        for (px, samples) in sps.chunks(cfg.spp as usize).enumerate() {
            let c = covered(px as u32);
            let e: Vec<f32> = samples.iter().map(|s| s.emitted[0] / le).collect();
            for x in &e {
                assert!(
                    (x * strata - (x * strata).round()).abs() < 1e-4,
                    "{backend}: pixel {px}: emission {x} L is not a multiple of 1/16"
                );
            }
            if c > 0.2 && c < 0.8 {
                let mean = e.iter().sum::<f32>() / e.len() as f32;
                let sd = (e.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>()
                    / (e.len() - 1) as f32)
                    .sqrt();
                // One ray: sqrt(c (1 - c)) >= 0.4 here.
                worst_spread = worst_spread.max(sd / (c * (1.0 - c)).sqrt());
            }
        }
        println!("{backend}: a sample's emission spreads {worst_spread:.3} of one ray's at worst");
        assert!(
            worst_spread < 0.35,
            "{backend}: stratified emission spreads {worst_spread} of one ray's"
        );
    }
}

/// The white GGX microfacet BRDF (Walter et al. 2007) between unit directions `wi` and `wo` about
/// the normal `n`, in f64 and in its tan θ form: D(h) = α² / (π cos⁴ θ_h (α² + tan² θ_h)²) and
/// Smith's separable G1(v) = 2 / (1 + √(1 + α² tan² θ_v)), f = D G1(wi) G1(wo) / (4 cos θ_i
/// cos θ_o). An evaluation independent of `vplgi_shared::bsdf`'s (Mitsuba's) form.
fn ggx_f64(n: Vec3, wi: Vec3, wo: Vec3, alpha: f64) -> f64 {
    let (n, wi, wo) = (n.as_dvec3(), wi.as_dvec3(), wo.as_dvec3());
    let (ci, co) = (n.dot(wi), n.dot(wo));
    if ci <= 0.0 || co <= 0.0 {
        return 0.0;
    }
    let h = (wi + wo).normalize();
    let ch = n.dot(h);
    let tan2 = |c: f64| (1.0 - c * c).max(0.0) / (c * c);
    let a2 = alpha * alpha;
    let d = a2 / (std::f64::consts::PI * ch.powi(4) * (a2 + tan2(ch)).powi(2));
    let g1 = |c: f64| 2.0 / (1.0 + (1.0 + a2 * tan2(c)).sqrt());
    d * g1(ci) * g1(co) / (4.0 * ci * co)
}

/// A point light of intensity I at height h over a rough metal or half-metal plane of colour ρ,
/// seen from straight above: the radiance at a plane point is ρ f(v, l) I cos θ_l / d², f the
/// white GGX BRDF of [`ggx_f64`] for the metal, (1 − m) / π + m f for a blend of metal share
/// m. With no VPLs the image is exactly that (up to f32 rounding), on both backends: the shading
/// points' view direction, the receiver's lobe and direct light together.
#[test]
fn point_light_over_rough_metal_matches_the_ggx_formula_on_both_backends() {
    use vplgi_shared::bsdf::Surface;
    let (h, rho, intensity) = (1.2f32, 0.7f32, 4.0f32);
    let gpu =
        vplgi_tests::gpu("point_light_over_rough_metal_matches_the_ggx_formula_on_both_backends")
            .map(|ctx| (vplgi_gpu::GpuKernels::new(&ctx.device).unwrap(), ctx));
    for surface in [
        Surface::RoughConductor { alpha: 0.09 },
        Surface::RoughConductor { alpha: 0.36 },
        Surface::Blend { metallic: 0.4, alpha: 0.09 },
    ] {
        let mut scene = plane_with_point_light(2.0, h, rho, intensity);
        scene.materials[0].surface = surface;
        let (cfg, sps, cpu) = direct_light_frame(&scene);
        let gpu = gpu.as_ref().map(|(kernels, ctx)| {
            vplgi_gpu::render(&ctx.device, &ctx.queue, kernels, &scene, &cfg).unwrap().pixels
        });
        let (eye, light) = (scene.camera.position, Vec3::new(0.0, h, 0.0));
        for (backend, pixels) in [("CPU", Some(&cpu)), ("GPU", gpu.as_ref())] {
            let Some(pixels) = pixels else { continue };
            let (mut worst, mut checked) = (0.0f64, 0);
            for (sp, px) in sps.iter().zip(pixels) {
                if sp.is_miss() {
                    continue;
                }
                let p = Vec3::from(sp.position);
                let (v, l) = ((eye - p).normalize(), (light - p).normalize());
                let f = match surface {
                    Surface::RoughConductor { alpha } => ggx_f64(Vec3::Y, v, l, alpha as f64),
                    Surface::Blend { metallic, alpha } => {
                        (1.0 - metallic as f64) / std::f64::consts::PI
                            + metallic as f64 * ggx_f64(Vec3::Y, v, l, alpha as f64)
                    }
                    _ => unreachable!(),
                };
                let expected = rho as f64 * f * intensity as f64 * l.y as f64
                    / (light - p).length_squared() as f64;
                worst = worst.max((px[0] as f64 - expected).abs() / expected);
                checked += 1;
            }
            println!(
                "{backend}, {}: {checked} pixels, worst relative error {worst:.2e}",
                surface.describe()
            );
            assert!(checked > 500, "the plane must fill most of the image");
            assert!(
                worst < 1e-4,
                "{backend}, {}: worst relative error {worst}",
                surface.describe()
            );
        }
    }
}

/// One VPL of flux Φ at height h over a plane, by the white GGX BRDF f of [`ggx_f64`]: a rough
/// metal VPL lit from ω_in lights a diffuse plane of albedo ρ with Φ f(ω_in, ω_p) cos θ_c
/// cos θ_p / d² ρ / π; a diffuse VPL lights a rough metal plane of colour ρ seen from ω_v with Φ
/// cos θ_c / π cos θ_p / d² ρ f(ω_v, ω_c), and the clamp caps π f G at g_max (Eq. 6 with both
/// lobes, `shade`'s module equation).
#[test]
fn one_glossy_vpl_and_one_glossy_receiver_match_the_ggx_formula() {
    use vplgi_scene::Material;
    use vplgi_shared::bsdf::Surface;
    let (h, rho, alpha) = (0.8f32, 0.5f32, 0.36f32);
    let flux = Vec3::new(2.0, 1.0, 0.5);
    let material = |surface| Material {
        name: String::new(),
        base_color: Vec3::splat(rho),
        base_color_texture: None,
        emission: Vec3::ZERO,
        surface,
    };
    let materials = [material(Surface::Diffuse), material(Surface::RoughConductor { alpha })];
    let x = Vec3::new(0.0, h, 0.0);
    let incoming = Vec3::new(0.5, -0.6, 0.1).normalize();
    let view = Vec3::new(-0.3, 1.0, 0.2).normalize();
    let mut matrix = BitMatrix::new(1, 1);
    matrix.set(0, 0);
    let row_of = [0u32];
    let vis = VisibilitySource::Own { matrix: &matrix, row_of: &row_of, first_row: 0 };
    let mut worst = 0.0f64;
    for r in [0.0f32, 0.3, 1.0, 2.5] {
        let p = Vec3::new(r, 0.0, 0.2 * r);
        let d2 = (x - p).length_squared() as f64;
        let (to_light, cos) = ((x - p).normalize(), (h as f64) / d2.sqrt());
        let g = cos * cos / d2;
        let sp = |material: u32| ShadingPoint {
            position: p.to_array(),
            normal: [0.0, 1.0, 0.0],
            albedo: [rho; 3],
            material,
            view: view.to_array(),
            ..Default::default()
        };
        let light = |material: u32| VplLight {
            material,
            incoming: incoming.to_array(),
            ..VplLight::new(x, -Vec3::Y, flux)
        };
        let pi = std::f64::consts::PI;
        let cases = [
            // A glossy VPL over a diffuse plane.
            (
                sp(0),
                light(1),
                f32::INFINITY,
                ggx_f64(-Vec3::Y, incoming, -to_light, alpha as f64) * g * rho as f64 / pi,
            ),
            // A diffuse VPL over a glossy plane, unclamped and clamped at a third of π f G.
            (
                sp(1),
                light(0),
                f32::INFINITY,
                g / pi * rho as f64 * ggx_f64(Vec3::Y, view, to_light, alpha as f64),
            ),
        ];
        for (point, vpl, g_max, per_flux) in cases {
            let got = indirect(
                &materials,
                &point,
                0,
                &LightArrays::new(&vec![vpl].into(), &materials),
                &vis,
                g_max,
            );
            for k in 0..3 {
                let want = flux[k] as f64 * per_flux;
                worst = worst.max((got[k] as f64 - want).abs() / want);
            }
        }
        let kernel = pi * ggx_f64(Vec3::Y, view, to_light, alpha as f64) * g;
        let cap = (kernel / 3.0) as f32;
        let got = indirect(
            &materials,
            &sp(1),
            0,
            &LightArrays::new(&vec![light(0)].into(), &materials),
            &vis,
            cap,
        );
        let want = flux.x as f64 / pi * rho as f64 / pi * cap as f64;
        worst = worst.max((got.x as f64 - want).abs() / want);
    }
    println!("one glossy VPL, one glossy receiver: worst relative error {worst:.2e}");
    assert!(worst < 1e-4, "worst relative error {worst}");
}
