//! `bias_points`, the bias compensation of the geometry-term clamp: an oracle on both backends
//! (compensated frames equal unclamped ones, which never run the compensation code, while
//! clamped frames lose a measured share of their light), and the GPU's compensation points
//! against the CPU's. Each test prints the measured disagreement.

use vplgi_cpu::CpuScene;
use vplgi_frame::{render, Backend};
use vplgi_gpu::GpuBackend;
use vplgi_scene::cornell::cornell_box;
use vplgi_types::{CameraParams, ClusterMode, FrameConfig};

/// A large clamp (d_min = half the diagonal) so that it removes a good share of the light.
const G_CLAMP: f32 = 0.5;

fn config(seed: u32) -> FrameConfig {
    FrameConfig {
        width: 32,
        height: 32,
        spp: 1,
        vpls: 3000,
        bounces: 2,
        cluster: ClusterMode::None,
        seed,
        g_clamp_rel: G_CLAMP,
        ..FrameConfig::reference()
    }
}

fn luminance(pixels: &[[f32; 3]]) -> f64 {
    let m = vplgi_tests::mean_rgb(pixels);
    0.2126 * m[0] + 0.7152 * m[1] + 0.0722 * m[2]
}

/// Per seed (the same VPLs in all three): the unclamped, clamped and compensated image means.
fn three_ways<B: Backend>(b: &B, seeds: std::ops::Range<u32>) -> Vec<(f64, f64, f64)>
where
    B::Error: std::fmt::Debug,
{
    three_ways_over(b, seeds, None, G_CLAMP)
}

/// [`three_ways`] over the pixels `mask` keeps (all of them without one), with the clamp at
/// `g_clamp` of the diagonal.
fn three_ways_over<B: Backend>(
    b: &B,
    seeds: std::ops::Range<u32>,
    mask: Option<&[bool]>,
    g_clamp: f32,
) -> Vec<(f64, f64, f64)>
where
    B::Error: std::fmt::Debug,
{
    let frame = |cfg: FrameConfig| {
        let pixels = render(b, &cfg, &vplgi_frame::NoProgress).expect("frame").pixels;
        match mask {
            Some(m) => luminance(
                &pixels.iter().zip(m).filter(|(_, &k)| k).map(|(p, _)| *p).collect::<Vec<_>>(),
            ),
            None => luminance(&pixels),
        }
    };
    seeds
        .map(|seed| {
            let c = FrameConfig { g_clamp_rel: g_clamp, ..config(seed) };
            let unclamped =
                frame(FrameConfig { g_clamp_rel: 0.0, bias_compensation: false, ..c.clone() });
            let clamped = frame(FrameConfig { bias_compensation: false, ..c.clone() });
            let compensated = frame(FrameConfig { bias_compensation: true, ..c });
            (unclamped, clamped, compensated)
        })
        .collect()
}

/// The compensated frame estimates the unclamped one: their paired difference over seeds is
/// within 4 standard errors of 0 and below a fifth of what the clamp removes (which must be
/// more than 3 % of the image, or the test would prove nothing).
fn check_compensation(backend: &str, runs: &[(f64, f64, f64)]) {
    let k = runs.len() as f64;
    let diffs: Vec<f64> = runs.iter().map(|r| r.2 - r.0).collect();
    let mean = diffs.iter().sum::<f64>() / k;
    let se = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt();
    let unclamped = runs.iter().map(|r| r.0).sum::<f64>() / k;
    let loss = runs.iter().map(|r| r.0 - r.1).sum::<f64>() / k;
    println!(
        "{backend}: unclamped mean {unclamped:.5}; the clamp removes {loss:.5} ({:.2} %); compensated - unclamped = {mean:+.5} +- {se:.5} \
         ({:+.2} % of the removed light)",
        100.0 * loss / unclamped,
        100.0 * mean / loss
    );
    assert!(
        loss > 0.03 * unclamped,
        "{backend}: the clamp removes only {loss} of {unclamped}: the test would prove nothing"
    );
    assert!(
        mean.abs() <= 4.0 * se + 1e-6,
        "{backend}: compensated - unclamped = {mean} with standard error {se}"
    );
    assert!(
        mean.abs() <= 0.2 * loss,
        "{backend}: compensated - unclamped = {mean}, against {loss} removed by the clamp"
    );
}

#[test]
fn compensation_puts_back_what_the_clamp_removes_on_the_cpu() {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    check_compensation("cpu", &three_ways(&cs, 1..7));
}

#[test]
fn compensation_puts_back_what_the_clamp_removes_on_the_gpu() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("compensation_puts_back_what_the_clamp_removes_on_the_gpu")
    else {
        return;
    };
    let scene = cornell_box();
    let gb = GpuBackend::new(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels, &scene).unwrap();
    check_compensation("gpu", &three_ways(&gb, 1..7));
}

/// The same where only glossy peaks are clamped: a rough metal floor (GGX α 0.09) one unit under
/// a lit diffuse ceiling, the clamp at d_min = 0.95, so no pair of surfaces is close enough for G
/// alone to pass g_max, but a_p G does in the floor's peak. Over the pixels that see the floor,
/// the compensation (which samples the metal's BSDF) puts the peaks back, on both backends.
#[test]
fn compensation_puts_back_the_glossy_peaks_the_clamp_cuts() {
    let scene = vplgi_tests::inputs::point_light_between_rough_metal_and_ceiling();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let g_clamp = 0.95 / scene.extent();
    let sps =
        vplgi_cpu::shading_points::shading_points(&cs, &config(0).camera_params(scene.camera));
    let floor: Vec<bool> = sps.iter().map(|sp| !sp.is_miss() && sp.material == 0).collect();
    println!("{} of {} pixels see the floor", floor.iter().filter(|&&m| m).count(), floor.len());
    check_compensation("cpu, glossy peaks", &three_ways_over(&cs, 1..9, Some(&floor), g_clamp));
    if let Some(gpu) =
        vplgi_tests::shared_gpu("compensation_puts_back_the_glossy_peaks_the_clamp_cuts")
    {
        let gb = GpuBackend::new(&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels, &scene).unwrap();
        check_compensation("gpu, glossy peaks", &three_ways_over(&gb, 1..9, Some(&floor), g_clamp));
    }
}

/// The GPU's compensation points of the CPU's shading points, by `vplgi verify`'s comparison:
/// the same surfaces (ties on shared edges counted as agreement; SPEC's shading-point bound) and
/// the same weights; and each level draws its own directions.
#[test]
fn bias_points_match_the_cpu() {
    let Some(gpu) = vplgi_tests::shared_gpu("bias_points_match_the_cpu") else {
        return;
    };
    let scene = cornell_box();
    let (w, h, spp) = (64, 64, 2);
    vplgi_tests::with_twins(gpu, &scene, |t| {
        let mut parents = vplgi_cpu::shading_points::shading_points(
            t.cpu,
            &CameraParams::new(t.cpu.scene.camera, w, h, spp, 5),
        );
        for level in 1..=2 {
            let params = config(5).bias_params(t.cpu.extent, level);
            let kept = vplgi_cpu::bias_points::bias_points(t.cpu, &parents, 0, &params);
            let n = kept.iter().filter(|p| !p.is_miss()).count();
            println!("level {level}: {n} of {} parents kept", parents.len());
            assert!(
                n > 200,
                "level {level}: only {n} compensation points: the test would prove little"
            );
            for c in
                vplgi_verify::bias_points::compare(t, &parents, (w, spp), &params).expect("GPU")
            {
                c.check();
            }
            // Each level draws its own directions: level 2's from level 1's parents differ.
            if level == 1 {
                let again = vplgi_cpu::bias_points::bias_points(
                    t.cpu,
                    &parents,
                    0,
                    &config(5).bias_params(t.cpu.extent, 2),
                );
                assert_ne!(kept, again, "levels 1 and 2 drew the same directions");
            }
            parents = kept;
        }
    });
}

proptest::proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Compensation points on random triangle soups and rooms, from the CPU's camera samples,
    /// with a random clamp (d_min from 2 % to 40 % of the diagonal) and seed: `vplgi verify`'s
    /// comparison, against the SPEC's shading-point row and the weight bound.
    #[test]
    fn bias_points_match_the_cpu_on_random_scenes(
        scene in vplgi_tests::inputs::random_scene(),
        width in 32u32..64,
        height in 32u32..64,
        g_clamp in 0.02f32..0.4,
        seed in proptest::prelude::any::<u32>(),
        glossy in proptest::prelude::any::<bool>(),
    ) {
        let Some(gpu) = vplgi_tests::shared_gpu("bias_points_match_the_cpu_on_random_scenes") else { return Ok(()) };
        let scene = if glossy { vplgi_tests::inputs::with_rough_metal(scene) } else { scene };
        println!("{}", scene.name);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| {
            let cfg = FrameConfig { width, height, spp: 1, seed, g_clamp_rel: g_clamp, ..FrameConfig::reference() };
            let parents = vplgi_cpu::shading_points::shading_points(t.cpu, &CameraParams::new(t.cpu.scene.camera, width, height, 1, seed));
            vplgi_verify::bias_points::compare(t, &parents, (width, 1), &cfg.bias_params(t.cpu.extent, 1))
        })
        .expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// No VPL sits on a mirror or glass, so the clamp removes no light that arrives from one: a
/// compensation segment that meets a specular surface keeps no point, on both backends. In the
/// Cornell box with a mirror wall and sphere, with a clamp large enough that hundreds of
/// segments reach them (counted by tracing the same directions here).
#[test]
fn compensation_stops_at_mirrors_and_glass() {
    let scene =
        vplgi_scene::generate::generate("cornell-mirror", 2_000).expect("a generated scene");
    let device = vplgi_embree::Device::new(None).expect("Embree device");
    let cs = CpuScene::new(&scene, &device).expect("Embree scene");
    let (w, h) = (64, 64);
    let parents = vplgi_cpu::shading_points::shading_points(
        &cs,
        &CameraParams::new(scene.camera, w, h, 1, 9),
    );
    let params = config(9).bias_params(cs.extent, 1);
    // The segments bias_point traces: cosine-sampled from each parent with the bias stream.
    let reaching = parents
        .iter()
        .enumerate()
        .filter(|(_, p)| !p.is_miss())
        .filter(|(i, p)| {
            let mut rng = vplgi_types::Rng::new(params.seed, vplgi_types::Stream::Bias, *i as u32);
            let n = glam::Vec3::from(p.normal);
            let dir = vplgi_types::sampling::cosine_hemisphere(n, rng.next_f32(), rng.next_f32());
            let start = glam::Vec3::from(p.position) + n * cs.eps;
            cs.trace(start, dir).is_some_and(|hit| hit.bsdf().is_specular())
        })
        .count();
    println!("{reaching} of {} segments meet a mirror", parents.len());
    assert!(reaching > 100, "only {reaching} segments meet a mirror: the test would prove little");
    let mut sides = vec![("CPU", vplgi_cpu::bias_points::bias_points(&cs, &parents, 0, &params))];
    if let Some(gpu) = vplgi_tests::shared_gpu("compensation_stops_at_mirrors_and_glass") {
        let gpu_points = vplgi_tests::with_twins(gpu, &scene, |t| {
            vplgi_verify::bias_points::both(t, &parents, &params).expect("GPU").1
        });
        sides.push(("GPU", gpu_points));
    }
    for (side, points) in sides {
        let kept = points.iter().filter(|p| !p.is_miss()).count();
        let on_specular = points
            .iter()
            .filter(|p| !p.is_miss() && scene.surface(p.triangle as usize).is_specular())
            .count();
        println!("{side}: {kept} compensation points, {on_specular} on a mirror");
        assert!(kept > 200, "{side}: only {kept} compensation points");
        assert_eq!(on_specular, 0, "{side}: compensation points on mirrors");
    }
}
