//! An independent estimator: a brute-force one-bounce path tracer, written here for the test,
//! against the `--cluster none --bounces 1` reference on the built-in Cornell box.
//!
//! The path tracer shares only the scene, Embree's closest-hit query and the RNG with the
//! pipeline; it samples lights its own way (uniform by area) and gathers indirect light by
//! cosine-sampling a bounce from the visible point and estimating direct light where it lands.
//! VPLs estimate the same integral (emitted + direct + one indirect bounce).
//!
//! Bounds, and why:
//! * With the geometry-term clamp disabled the VPL reference is unbiased, so image means agree
//!   within the two estimators' noise: 4 standard errors of the difference (the VPL estimate's
//!   standard error from independent seeds, the path tracer's from its per-sample variance).
//! * The clamp (d_min = 5 % of the scene diagonal) can only remove energy. Its loss is measured
//!   as the mean difference between unclamped and clamped renders with the same VPLs and must
//!   stay below 2 % of the indirect light — the SPEC's calibration found < 0.1 % of all light.

use glam::Vec3;
use std::f32::consts::PI;
use vplgi_cpu::CpuScene;
use vplgi_scene::cornell::cornell_box;
use vplgi_types::{sampling, ClusterMode, FrameConfig, Rng, Stream};

const SIZE: u32 = 24;

/// Direct light leaving `x` towards anything, per unit albedo/π, from one uniform-area sample
/// of the emitters.
fn direct_at(
    cs: &CpuScene,
    emitters: &[(usize, f32)],
    total_area: f32,
    x: Vec3,
    n: Vec3,
    rng: &mut Rng,
) -> Vec3 {
    // Pick an emitter proportionally to area, then a uniform point on it.
    let u = rng.next_f32() * total_area;
    let mut acc = 0.0;
    let mut pick = emitters[emitters.len() - 1];
    for &e in emitters {
        acc += e.1;
        if u < acc {
            pick = e;
            break;
        }
    }
    let (b1, b2) = sampling::uniform_triangle(rng.next_f32(), rng.next_f32());
    let [a, b, c] = cs.scene.triangle(pick.0);
    let y = a + (b - a) * b1 + (c - a) * b2;
    let ny = cs.scene.geometric_normal(pick.0);
    let d = y - x;
    let d2 = d.length_squared();
    let cos_x = n.dot(d) / d2.sqrt();
    let cos_y = -ny.dot(d) / d2.sqrt();
    if cos_x <= 0.0 || cos_y <= 0.0 || !cs.visible(x, n, y, ny) {
        return Vec3::ZERO;
    }
    cs.scene.emission(pick.0) * (cos_x * cos_y / d2 * total_area)
}

/// Mean radiance over the image, and the standard error of that mean, from `spp` paths per pixel.
fn path_trace(cs: &CpuScene, spp: u32) -> ([f64; 3], [f64; 3]) {
    let emitters: Vec<(usize, f32)> = (0..cs.scene.triangle_count())
        .filter(|&t| cs.scene.emission(t).max_element() > 0.0)
        .map(|t| {
            let [a, b, c] = cs.scene.triangle(t);
            (t, 0.5 * (b - a).cross(c - a).length())
        })
        .collect();
    let total_area: f32 = emitters.iter().map(|e| e.1).sum();
    let cam = cs.scene.camera;
    let mut sum = [0.0f64; 3];
    let mut sum2 = [0.0f64; 3];
    let n = SIZE * SIZE * spp;
    for i in 0..n {
        let px = i / spp;
        let mut rng = Rng::new(99, Stream::Oracle, i);
        // Pixel centres, like the reference at spp = 1: both estimate the same pixel values.
        let dir = cam.ray_direction((px % SIZE) as f32 + 0.5, (px / SIZE) as f32 + 0.5, SIZE, SIZE);
        let mut l = Vec3::ZERO;
        if let Some(h) = cs.trace(cam.position, dir) {
            l += h.emitted;
            l += h.albedo / PI * direct_at(cs, &emitters, total_area, h.position, h.ns, &mut rng);
            let w = sampling::cosine_hemisphere(h.ns, rng.next_f32(), rng.next_f32());
            if w.dot(h.ng) > 0.0 {
                if let Some(x) = cs.trace(h.position + h.ng * cs.eps, w) {
                    // Cosine sampling: BRDF * cos / pdf = albedo.
                    l += h.albedo * x.albedo / PI
                        * direct_at(cs, &emitters, total_area, x.position, x.ns, &mut rng);
                }
            }
        }
        for c in 0..3 {
            sum[c] += l[c] as f64;
            sum2[c] += (l[c] as f64).powi(2);
        }
    }
    let n = n as f64;
    let mean = sum.map(|s| s / n);
    let se = [0, 1, 2].map(|c| ((sum2[c] / n - mean[c] * mean[c]).max(0.0) / (n - 1.0)).sqrt());
    (mean, se)
}

#[test]
fn one_bounce_path_tracer_agrees_with_the_unclustered_reference() {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).expect("device");
    let cs = CpuScene::new(&scene, &device).expect("scene");
    let (pt, pt_se) = path_trace(&cs, 2048);

    // The clamp's loss is measured without its compensation (tests/tests/bias_points.rs checks that).
    let base = FrameConfig {
        width: SIZE,
        height: SIZE,
        cluster: ClusterMode::None,
        bounces: 1,
        vpls: 20_000,
        direct_samples: 16,
        bias_compensation: false,
        ..FrameConfig::reference()
    };
    let seeds = [1u32, 2, 3, 4];
    let mut unclamped = Vec::new();
    let mut loss = [0.0f64; 3];
    let mut direct_only = [0.0f64; 3];
    for &seed in &seeds {
        let u = vplgi_cpu::render(
            &cs,
            &FrameConfig { seed, g_clamp_rel: 0.0, ..base.clone() },
            &vplgi_cpu::NoProgress,
        )
        .unwrap();
        let c =
            vplgi_cpu::render(&cs, &FrameConfig { seed, ..base.clone() }, &vplgi_cpu::NoProgress)
                .unwrap();
        let d = vplgi_cpu::render(
            &cs,
            &FrameConfig { seed, vpls: 0, ..base.clone() },
            &vplgi_cpu::NoProgress,
        )
        .unwrap();
        let (mu, mc, md) = (
            vplgi_tests::mean_rgb(&u.pixels),
            vplgi_tests::mean_rgb(&c.pixels),
            vplgi_tests::mean_rgb(&d.pixels),
        );
        for ch in 0..3 {
            assert!(mc[ch] <= mu[ch] + 1e-9, "the clamp added energy");
            loss[ch] += (mu[ch] - mc[ch]) / seeds.len() as f64;
            direct_only[ch] += md[ch] / seeds.len() as f64;
        }
        unclamped.push(mu);
    }
    let k = seeds.len() as f64;
    for ch in 0..3 {
        let mean = unclamped.iter().map(|m| m[ch]).sum::<f64>() / k;
        let var = unclamped.iter().map(|m| (m[ch] - mean).powi(2)).sum::<f64>() / (k - 1.0);
        let se_vpl = (var / k).sqrt();
        let se = (se_vpl * se_vpl + pt_se[ch] * pt_se[ch]).sqrt();
        let indirect = mean - direct_only[ch];
        println!(
            "channel {ch}: path tracer {:.5} ± {:.5}, VPL reference (unclamped) {:.5} ± {:.5}, difference {:+.2} σ; \
             indirect {:.5}, clamp loss {:.2e} ({:.3} % of indirect)",
            pt[ch],
            pt_se[ch],
            mean,
            se_vpl,
            (mean - pt[ch]) / se,
            indirect,
            loss[ch],
            100.0 * loss[ch] / indirect
        );
        assert!(
            (mean - pt[ch]).abs() <= 4.0 * se,
            "channel {ch}: VPL reference {mean} vs path tracer {} (4σ = {})",
            pt[ch],
            4.0 * se
        );
        assert!(
            loss[ch] <= 0.02 * indirect,
            "channel {ch}: the clamp removed {} of {} indirect",
            loss[ch],
            indirect
        );
    }
}
