//! `interpolate` (`--shade interpolate`, Wang et al. 2009): the GPU's irradiance samples and
//! interpolated images against the CPU's on random scenes (SPEC: the shade row), measured by
//! `vplgi verify`'s comparison; and, on both backends against computations written here, the
//! interpolation weights on hand-checked points and a white furnace, where every sample point
//! receives the same irradiance and the interpolation must return it at every shading point.

use glam::{DVec3, Vec3};
use proptest::prelude::*;
use std::f64::consts::PI;
use vplgi_cpu::interpolate::IrradianceSamples;
use vplgi_cpu::shade::{LightArrays, VisibilitySource};
use vplgi_gpu::buffers::{read_back, storage, Window};
use vplgi_gpu::interpolate::{GpuIrradianceSamples, InterpolateInputs, SampleLighting};
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::{
    ClusterMode, Endpoint, FrameConfig, FuzzyMode, ShadeMode, ShadingPoint, VplLight, MISS,
};
use vplgi_verify::inputs::CpuFrame;
use vplgi_verify::Mode;

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(6))]

    /// Random scenes and frames, K from a few to a third of the hits, F from 1 to 8, 1 to 40
    /// gather rays: the irradiance samples and the interpolated image agree (the radii are judged
    /// by their own stage's test).
    #[test]
    fn interpolate_matches_the_cpu_on_random_scenes(
        scene in vplgi_tests::inputs::random_scene(),
        (width, height) in (8u32..64, 8u32..48),
        k_share in 0.01f32..0.3,
        f in 1u32..=8,
        rays in 1u32..40,
        both in any::<bool>(),
        seed in any::<u32>(),
    ) {
        let Some(gpu) = vplgi_tests::shared_gpu("interpolate_matches_the_cpu_on_random_scenes") else { return Ok(()) };
        let k_sp = ((width * height) as f32 * k_share).max(1.0) as u32;
        let cluster = if both { ClusterMode::Both } else { ClusterMode::Sp };
        let cfg = FrameConfig { width, height, k_sp, f, gather_rays: rays, cluster, shade: ShadeMode::Interpolate, seed, vpls: 500, k_vpl: 60, ..FrameConfig::verify() };
        println!("{}: {width}x{height}, K {k_sp}, F {f}, {rays} gather rays, {cluster:?}", scene.name);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| -> Result<_, vplgi_verify::VerifyError> {
            let frame = CpuFrame::new(t.cpu, &cfg);
            if frame.hits.is_empty() {
                return Ok(Vec::new());
            }
            let mut checks = vplgi_verify::interpolate::compare_samples(t, &cfg, &frame)?;
            checks.extend(vplgi_verify::shade::compare_on(t, &Mode::of(&cfg).apply(&cfg), &frame)?.0);
            Ok(checks)
        }).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// Interpolated irradiance at `sps` on both backends, from hand-made samples (`lit`: the samples'
/// irradiance comes from `light`, every sample seeing it; else `samples.irradiance` as given).
fn both(
    scene: &vplgi_scene::Scene,
    sps: &[ShadingPoint],
    labels: &[u32],
    f: u32,
    samples: &IrradianceSamples,
    light: Option<VplLight>,
) -> Option<(Vec<Vec3>, Vec<Vec3>)> {
    let gpu = vplgi_tests::shared_gpu("interpolate")?;
    let n = samples.points.len();
    let row_of: Vec<u32> = (0..sps.len() as u32).collect();
    let mut matrix = vplgi_cpu::visibility::BitMatrix::new(n, 1);
    for j in 0..n {
        matrix.set(j, 0);
    }
    let lights: vplgi_cpu::shade::VplLights = light.into_iter().collect::<Vec<VplLight>>().into();
    let mut cpu_samples = samples.clone();
    if light.is_some() {
        cpu_samples.irradiance = vplgi_cpu::shade::sample_irradiance(
            &[],
            &samples.points,
            &lights,
            &matrix,
            f32::INFINITY,
        );
    }
    let vis = VisibilitySource::Interpolated {
        row_of: &row_of,
        labels,
        f: f as usize,
        samples: &cpu_samples,
    };
    let arrays = LightArrays::new(&lights, &[]);
    let cpu: Vec<Vec3> = (0..sps.len())
        .map(|i| {
            vplgi_cpu::shade::irradiance(
                sps[i].position.into(),
                sps[i].normal.into(),
                vplgi_cpu::shade::receiver(&scene.materials, &sps[i]),
                i,
                &arrays,
                &vis,
                f32::INFINITY,
            )
        })
        .collect();
    let gpu_values = vplgi_tests::with_twins(gpu, scene, |t| {
        let (device, queue) = (t.device(), t.queue());
        let k = t.gpu.kernels();
        let points = storage(device, "sample points", &samples.points);
        let inv_radius = storage(device, "inverse radii", &samples.inv_radius);
        let gs = match light {
            Some(_) => {
                let words =
                    storage(device, "words", bytemuck::cast_slice::<u64, u32>(matrix.words()));
                let lb = storage(device, "lights", &lights.lights);
                let lighting = SampleLighting {
                    words: &words,
                    words_per_row: words_per_row(1) as u32,
                    vpl_lights: &lb,
                    outlines: None,
                    light_count: 1,
                    exact_shapes: false,
                    lobes: None,
                    g_max: f32::INFINITY,
                };
                k.interpolate
                    .sample_irradiance(
                        device,
                        queue,
                        &k.shade,
                        (points, n as u32),
                        inv_radius,
                        &lighting,
                    )
                    .expect("samples")
            }
            None => {
                let e: Vec<[f32; 4]> =
                    samples.irradiance.iter().map(|e| [e[0], e[1], e[2], 0.0]).collect();
                GpuIrradianceSamples {
                    points,
                    inv_radius,
                    irradiance: storage(device, "irradiance", &e),
                    sh: (!samples.sh.is_empty()).then(|| storage(device, "harmonics", &samples.sh)),
                    count: n as u32,
                }
            }
        };
        let (sb, rb, lb) = (
            storage(device, "sps", sps),
            storage(device, "row_of", &row_of),
            storage(device, "labels", labels),
        );
        let inputs = InterpolateInputs {
            sps: &sb,
            sp_first: 0,
            row_of: &rb,
            labels: &lb,
            f,
            window: Window { first: 0, count: sps.len() as u64 },
            lobes: &t.gpu.scene().lobes,
        };
        let out = k
            .interpolate
            .run(device, queue, &gs, &inputs, 0..sps.len() as u32)
            .expect("interpolate");
        read_back::<[f32; 4]>(device, queue, &out, sps.len()).expect("read back")
    });
    Some((cpu, gpu_values.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect()))
}

fn point(p: Vec3, n: Vec3) -> ShadingPoint {
    ShadingPoint {
        position: p.to_array(),
        normal: n.to_array(),
        albedo: [0.5; 3],
        ..Default::default()
    }
}

/// Wang et al.'s weight 1 / (|x − s_j| / R_j + √(2 − 2 n·n_j)) and irradiance samples lit by one
/// VPL, computed here in f64 from the geometry. The VPL of flux Φ hangs at height h facing down
/// over the plane y = 0; sample points on the plane at x = 0 and x = 1 (normal up), and one at
/// x = 0.5 on a wall-like normal turned 60° towards the light, so that its normal term is 1.
/// Shading points between them, each with the three samples as its neighbourhood (one label
/// missing at the last point).
#[test]
fn interpolation_weights_on_hand_checked_points() {
    let (h, flux) = (0.8f64, DVec3::new(2.0, 1.0, 0.5));
    let light = VplLight::new(Vec3::new(0.0, h as f32, 0.0), -Vec3::Y, flux.as_vec3());
    let turned = DVec3::new(-(3f64.sqrt()) / 2.0, 0.5, 0.0);
    let sample_points =
        [(DVec3::ZERO, DVec3::Y), (DVec3::X, DVec3::Y), (DVec3::new(0.5, 0.0, 0.0), turned)];
    let inv_radius = [0.5f64, 2.0, 0.25];
    // Irradiance of the VPL at a sample: Φ cos θ_l cos θ_s / (π d²) (no clamp).
    let irradiance = |p: DVec3, n: DVec3| {
        let d = DVec3::new(0.0, h, 0.0) - p;
        let d2 = d.length_squared();
        let cos_s = n.dot(d) / d2.sqrt();
        let cos_l = d.y / d2.sqrt();
        flux * (cos_s.max(0.0) * cos_l / (PI * d2))
    };
    let xs = [0.1f64, 0.4, 0.75, 0.9];
    let labels: Vec<u32> = xs
        .iter()
        .enumerate()
        .flat_map(|(i, _)| if i == 3 { [0u32, MISS, 2] } else { [2u32, 0, 1] })
        .collect();
    let expected: Vec<DVec3> = xs
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            let (mut sum, mut total) = (DVec3::ZERO, 0.0);
            for &k in labels[i * 3..i * 3 + 3].iter().filter(|&&k| k != MISS) {
                let (s, n) = sample_points[k as usize];
                let w = 1.0
                    / ((DVec3::new(x, 0.0, 0.0) - s).length() * inv_radius[k as usize]
                        + (2.0 - 2.0 * n.dot(DVec3::Y)).sqrt());
                sum += irradiance(s, n) * w;
                total += w;
            }
            sum / total
        })
        .collect();
    let samples = IrradianceSamples {
        points: sample_points
            .iter()
            .map(|(p, n)| Endpoint::new(p.as_vec3(), n.as_vec3()))
            .collect(),
        inv_radius: inv_radius.iter().map(|&r| r as f32).collect(),
        irradiance: Vec::new(),
        sh: Vec::new(),
    };
    let sps: Vec<ShadingPoint> =
        xs.iter().map(|&x| point(Vec3::new(x as f32, 0.0, 0.0), Vec3::Y)).collect();
    let mut scene = vplgi_scene::cornell::plane_with_point_light(4.0, 1.0, 0.5, 1.0);
    scene.lights.clear();
    let Some((cpu, gpu)) = both(&scene, &sps, &labels, 3, &samples, Some(light)) else { return };
    for (i, e) in expected.iter().enumerate() {
        println!("x = {}: expected {e}, CPU {}, GPU {}", xs[i], cpu[i], gpu[i]);
        for (name, got) in [("CPU", cpu[i]), ("GPU", gpu[i])] {
            assert!(
                (got.as_dvec3() - *e).abs().max_element() <= 1e-6 * e.max_element(),
                "{name}: x = {}: {got} vs {e}",
                xs[i]
            );
        }
    }
}

/// A white furnace: every sample point receives the same irradiance E, so whatever the weights
/// (random positions, normals and radii, F of them per shading point, some labels missing) the
/// interpolation is E at every shading point, to within the rounding of a weighted mean.
#[test]
fn a_white_furnace_interpolates_to_its_irradiance_everywhere() {
    let mut rng = vplgi_types::Rng::new(11, vplgi_types::Stream::Oracle, 0);
    let mut u = || rng.next_f32();
    let unit = vplgi_types::sampling::uniform_sphere;
    let e = [0.37f32, 1.25, 3.5];
    let n_samples = 40;
    let samples = IrradianceSamples {
        points: (0..n_samples)
            .map(|_| Endpoint::new(Vec3::new(u(), u(), u()) * 4.0, unit(u(), u())))
            .collect(),
        inv_radius: (0..n_samples).map(|_| 10f32.powf(3.0 * u() - 2.0)).collect(),
        irradiance: vec![e; n_samples],
        sh: Vec::new(),
    };
    let f = 5u32;
    let sps: Vec<ShadingPoint> =
        (0..300).map(|_| point(Vec3::new(u(), u(), u()) * 4.0, unit(u(), u()))).collect();
    let labels: Vec<u32> = (0..sps.len() * f as usize)
        .map(|_| if u() < 0.15 { MISS } else { (u() * n_samples as f32) as u32 % n_samples as u32 })
        .collect();
    let scene = vplgi_scene::cornell::plane_with_point_light(4.0, 1.0, 0.5, 1.0);
    let Some((cpu, gpu)) = both(&scene, &sps, &labels, f, &samples, None) else { return };
    let mut worst = 0.0f32;
    for (i, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
        let any = labels[i * f as usize..(i + 1) * f as usize].iter().any(|&k| k != MISS);
        let expected = if any { Vec3::from(e) } else { Vec3::ZERO };
        for got in [c, g] {
            let rel = ((*got - expected).abs() / expected.max(Vec3::splat(1e-30))).max_element();
            worst = worst.max(if any { rel } else { got.abs().max_element() });
        }
    }
    println!(
        "white furnace: largest relative error {worst:e} over {} shading points, both backends",
        sps.len()
    );
    assert!(worst <= 4.0 * f32::EPSILON * f as f32, "largest relative error {worst:e}");
}

/// `--shade interpolate` with the two papers' other choices, on the Cornell box, end to end on
/// both backends: every stage ran (the report counts them) and the images agree where the hits do.
#[test]
fn interpolated_frames_render_on_both_backends() {
    let Some(gpu) = vplgi_tests::shared_gpu("interpolated_frames_render_on_both_backends") else {
        return;
    };
    let scene = vplgi_scene::cornell::cornell_box();
    let cfg = FrameConfig {
        width: 48,
        height: 48,
        k_sp: 200,
        fuzzy: FuzzyMode::Weighted,
        shade: ShadeMode::Interpolate,
        ..FrameConfig::verify()
    };
    let (cpu, gpu_frame) = vplgi_tests::with_twins(gpu, &scene, |t| {
        let cpu = vplgi_frame::render(t.cpu, &cfg, &vplgi_frame::NoProgress).expect("CPU frame");
        let gpu_frame =
            vplgi_frame::render(t.gpu, &cfg, &vplgi_frame::NoProgress).expect("GPU frame");
        (cpu, gpu_frame)
    });
    use vplgi_frame::Stage;
    for f in [&cpu, &gpu_frame] {
        assert!(
            f.stats.sp_clusters > 0
                && f.timings.get(Stage::GatherRadius) > 0.0
                && f.timings.get(Stage::Interpolate) > 0.0
        );
        assert!(f.pixels.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
    }
    let (c, g) = (vplgi_tests::mean_rgb(&cpu.pixels), vplgi_tests::mean_rgb(&gpu_frame.pixels));
    println!("mean CPU {c:?}, GPU {g:?}");
    for k in 0..3 {
        assert!((c[k] / g[k] - 1.0).abs() < 0.01, "channel {k}: CPU {} GPU {}", c[k], g[k]);
    }
}

/// The glossy last bounce (`--gi photon`): samples carrying spherical harmonics, shading points
/// on rough metal and on a metal-over-diffuse blend, each seen from its own direction. Both
/// backends must give `sh::glossy_irradiance` of the weighted means of the samples' coefficients
/// and irradiance, the means computed here in f64 with the weights written out again: the
/// interpolation of the coefficients, and the GPU's integration against the lobe.
#[test]
fn glossy_receivers_integrate_the_interpolated_harmonics() {
    use vplgi_shared::bsdf::Surface;
    use vplgi_shared::sh::{accumulate, glossy_irradiance, ShRgb};
    let mut rng = vplgi_types::Rng::new(12, vplgi_types::Stream::Oracle, 0);
    let mut u = || rng.next_f32();
    let unit = vplgi_types::sampling::uniform_sphere;
    let mut scene = vplgi_scene::cornell::plane_with_point_light(4.0, 1.0, 0.5, 1.0);
    scene.lights.clear();
    let metal = scene.materials[0].clone();
    scene.materials[0].surface = Surface::RoughConductor { alpha: 0.5 };
    scene.materials.push(vplgi_scene::Material {
        surface: Surface::Blend { metallic: 0.6, alpha: 0.8 },
        ..metal
    });
    let n_samples = 12;
    let mut samples = IrradianceSamples::default();
    for _ in 0..n_samples {
        let mut sh: ShRgb = Default::default();
        for _ in 0..3 {
            accumulate(&mut sh, unit(u(), u()), Vec3::new(u(), u(), u()) * 4.0);
        }
        samples.points.push(Endpoint::new(Vec3::new(u(), 0.0, u()) * 2.0, Vec3::Y));
        samples.inv_radius.push(0.5 + u());
        samples.irradiance.push([u() * 3.0, u() * 3.0, u() * 3.0]);
        samples.sh.push(sh);
    }
    let f = 4u32;
    let sps: Vec<ShadingPoint> = (0..60)
        .map(|i| {
            let n = (Vec3::Y + 0.3 * unit(u(), u())).normalize();
            let view = (n + unit(u(), u())).normalize();
            let view = if view.dot(n) > 0.05 { view } else { n };
            ShadingPoint {
                view: view.to_array(),
                material: i % 2,
                ..point(Vec3::new(u(), 0.0, u()) * 2.0, n)
            }
        })
        .collect();
    let labels: Vec<u32> = (0..sps.len() * f as usize)
        .map(|_| (u() * n_samples as f32) as u32 % n_samples as u32)
        .collect();
    let Some((cpu, gpu)) = both(&scene, &sps, &labels, f, &samples, None) else { return };
    let mut worst = 0.0f64;
    for (i, sp) in sps.iter().enumerate() {
        let (p, n) = (Vec3::from(sp.position).as_dvec3(), Vec3::from(sp.normal).as_dvec3());
        let (mut e, mut sh, mut total) = (DVec3::ZERO, [DVec3::ZERO; 16], 0.0f64);
        for &k in &labels[i * f as usize..(i + 1) * f as usize] {
            let s = &samples.points[k as usize];
            let w = 1.0
                / ((s.p().as_dvec3() - p).length() * samples.inv_radius[k as usize] as f64
                    + (2.0 - 2.0 * n.dot(s.n().as_dvec3())).max(0.0).sqrt());
            e += Vec3::from(samples.irradiance[k as usize]).as_dvec3() * w;
            for (acc, c) in sh.iter_mut().zip(&samples.sh[k as usize]) {
                *acc += Vec3::from(*c).as_dvec3() * w;
            }
            total += w;
        }
        let mean: ShRgb = std::array::from_fn(|c| (sh[c] / total).as_vec3().to_array());
        let surface = scene.materials[sp.material as usize].surface;
        let want = glossy_irradiance(
            &mean,
            (e / total).as_vec3(),
            surface,
            n.as_vec3(),
            Vec3::from(sp.view),
        );
        for (name, got) in [("CPU", cpu[i]), ("GPU", gpu[i])] {
            let rel = ((got - want).abs().max_element() / want.abs().max_element()) as f64;
            worst = worst.max(rel);
            assert!(rel < 1e-4, "{name}: shading point {i} ({surface:?}): {got} against {want}");
        }
    }
    println!("glossy interpolation: largest relative difference {worst:e} over {} shading points, both backends", sps.len());
}

/// A scene with rough metal: `--shade interpolate` with the VPL lights' samples is refused (they
/// hold irradiance alone), and `--gi photon` renders it on both backends, its glossy receivers
/// taking the glossy last bounce. Each backend chains its own photons, cut and clusters, whose
/// rounding moves the frame by about 1 % at these small sizes: the twins are judged stage by
/// stage (`final_gather`, `interpolate / glossy`), so here only the means are printed.
#[test]
fn glossy_scenes_interpolate_with_photons_only() {
    let Some(gpu) = vplgi_tests::shared_gpu("glossy_scenes_interpolate_with_photons_only") else {
        return;
    };
    let scene = vplgi_scene::generate::generate("cornell-glossy", 2_240).expect("cornell-glossy");
    let vpl = FrameConfig {
        width: 32,
        height: 32,
        k_sp: 100,
        shade: ShadeMode::Interpolate,
        ..FrameConfig::verify()
    };
    let photon = FrameConfig {
        width: 32,
        height: 32,
        k_sp: 100,
        global_photons: 20_000,
        gather_rays: 32,
        ..FrameConfig::photon()
    };
    let (refused, cpu, gpu_frame) = vplgi_tests::with_twins(gpu, &scene, |t| {
        let refused =
            vplgi_frame::render(t.cpu, &vpl, &vplgi_frame::NoProgress).err().map(|e| e.to_string());
        let cpu = vplgi_frame::render(t.cpu, &photon, &vplgi_frame::NoProgress).expect("CPU frame");
        let gpu_frame =
            vplgi_frame::render(t.gpu, &photon, &vplgi_frame::NoProgress).expect("GPU frame");
        (refused, cpu, gpu_frame)
    });
    let refused = refused.expect("--gi vpl interpolation of a glossy scene is refused");
    assert!(refused.contains("--gi photon"), "{refused}");
    for f in [&cpu, &gpu_frame] {
        assert!(f.pixels.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
    }
    let (c, g) = (vplgi_tests::mean_rgb(&cpu.pixels), vplgi_tests::mean_rgb(&gpu_frame.pixels));
    println!("cornell-glossy, --gi photon: mean CPU {c:?}, GPU {g:?}");
    // Lit: most pixels are not black on either backend.
    for f in [&cpu, &gpu_frame] {
        assert!(
            f.pixels.iter().filter(|p| p.iter().sum::<f32>() > 0.0).count() > f.pixels.len() / 2
        );
    }
}
