//! The paper's equations, each computed independently on a small hand-checked case and compared
//! with both backends. The differential tests prove the twins agree; these prove they agree with
//! the paper: a mistake made in both (say Eq. 10 with an inverse squared distance in
//! `vplgi-types` and in `cluster_assign.wgsl`) fails here.

use glam::Vec3;
use std::f32::consts::PI;
use vplgi_cpu::cluster::{bounds, Grid};
use vplgi_cpu::shade::{indirect, LightArrays, VisibilitySource};
use vplgi_cpu::visibility::BitMatrix;
use vplgi_gpu::buffers::{read_back, storage};
use vplgi_gpu::cluster::AssignRule;
use vplgi_gpu::shade::{ShadeInputs, Visibility};
use vplgi_gpu::visibility::words_per_row;
use vplgi_types::clustering::{GridGeometry, Metric};
use vplgi_types::{Endpoint, FuzzyMode, ShadeParams, ShadingPoint, VplLight};

/// n_t = cos 30°, the paper's threshold.
const N_T: f32 = 0.866_025_4;

/// Eq. 7 with n_t = `nt`.
fn eq7(nt: f32) -> Metric {
    Metric::Eq7 { normal_threshold: nt }
}

/// A point at the origin facing up, and five centroids on the +x axis: at distances 1, 2 and 4
/// facing up, one at 0.5 with normal `tilted`, and one at 8 facing up.
fn hand_checked_assignment(tilted: Vec3) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec3>, Vec<Vec3>) {
    let centroids = vec![
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::new(8.0, 0.0, 0.0),
    ];
    let normals = vec![Vec3::Y, Vec3::Y, Vec3::Y, tilted, Vec3::Y];
    (vec![Vec3::ZERO], vec![Vec3::Y], centroids, normals)
}

/// Both backends' labels and weights for the point of [`hand_checked_assignment`] with F = 3.
fn assign_both(
    fuzzy: FuzzyMode,
    tilted: Vec3,
    metric: Metric,
) -> Option<[(Vec<u32>, Vec<f32>); 2]> {
    let gpu = vplgi_tests::shared_gpu("equations: assignment")?;
    let (ps, ns, cs, cn) = hand_checked_assignment(tilted);
    let rule = AssignRule { metric, f: 3, fuzzy };
    // The grid is laid over the points and the centroids, so every centroid has a cell.
    let all: Vec<Vec3> = ps.iter().chain(&cs).copied().collect();
    let grid = Grid::for_data(bounds(&all), &all, cs.len()).fill(&cs, &cn);
    let cpu = vplgi_verify::cluster::cpu_assign(&grid, (&ps, &ns), rule);
    let (device, queue, kernel) = (&gpu.ctx.device, &gpu.ctx.queue, &gpu.kernels.cluster);
    let ends = |p: &[Vec3], n: &[Vec3]| -> Vec<Endpoint> {
        p.iter().zip(n).map(|(&p, &n)| Endpoint::new(p, n)).collect()
    };
    let (pts, cents) =
        (storage(device, "points", &ends(&ps, &ns)), storage(device, "centroids", &ends(&cs, &cn)));
    let g = kernel
        .fill_grid(
            device,
            queue,
            &GridGeometry { origin: grid.origin, cell: grid.cell, dims: grid.dims },
            &cents,
            cs.len() as u32,
        )
        .expect("grid");
    let a = kernel
        .assign(device, queue, &g, (&pts, 1), (&cents, cs.len() as u32), rule)
        .expect("assign");
    let gpu_result = (
        read_back(device, queue, &a.labels, 3).expect("labels"),
        read_back(device, queue, &a.weights, 3).expect("weights"),
    );
    Some([cpu, gpu_result])
}

/// The centroid at 0.5 of [`hand_checked_assignment`] tilted 60° from the point's normal (cos 0.5,
/// below n_t).
fn tilted_60() -> Vec3 {
    Vec3::new(60f32.to_radians().sin(), 60f32.to_radians().cos(), 0.0)
}

/// Eq. 7 and Eq. 10: the F = 3 nearest compatible centroids are those at 1, 2 and 4 (the one at
/// 0.5 is nearer but its normal is beyond n_t), and their weights are the normalised inverse
/// distances (1, 1/2, 1/4) / (7/4) = (4/7, 2/7, 1/7). An inverse squared distance would give
/// (16/21, 4/21, 1/21).
#[test]
fn eq_7_and_eq_10_on_a_hand_checked_point() {
    let Some(both) = assign_both(FuzzyMode::Weighted, tilted_60(), eq7(N_T)) else { return };
    for (name, (labels, weights)) in ["CPU", "GPU"].iter().zip(both) {
        println!("{name}: labels {labels:?}, weights {weights:?}");
        assert_eq!(
            labels,
            [0, 1, 2],
            "{name}: Eq. 7 picks the three compatible centroids, nearest first"
        );
        for (w, expected) in weights.iter().zip([4.0 / 7.0, 2.0 / 7.0, 1.0 / 7.0f32]) {
            assert!(
                (w - expected).abs() <= 1e-6,
                "{name}: Eq. 10 weights {weights:?}, expected (4/7, 2/7, 1/7)"
            );
        }
    }
}

/// Eq. 7's inequality is strict: a normal whose dot product with the point's is exactly n_t is
/// "otherwise", infinitely far. The centroid at 0.5 faces (0.6, 0.8, 0) and n_t is that 0.8
/// (both dot products are exact: 0 · 0.6 + 1 · 0.8 + 0 · 0), so it must not be chosen; one
/// float step lower and it is the nearest.
#[test]
fn eq_7_is_strict_at_the_threshold() {
    let tilted = Vec3::new(0.6, 0.8, 0.0);
    let Some(both) = assign_both(FuzzyMode::Weighted, tilted, eq7(0.8)) else { return };
    for (name, (labels, _)) in ["CPU", "GPU"].iter().zip(both) {
        assert_eq!(labels, [0, 1, 2], "{name}: n · m = n_t is not compatible");
    }
    let Some(both) = assign_both(FuzzyMode::Weighted, tilted, eq7(0.8f32.next_down())) else {
        return;
    };
    for (name, (labels, _)) in ["CPU", "GPU"].iter().zip(both) {
        assert_eq!(labels, [3, 0, 1], "{name}: n · m just above n_t is compatible, and nearest");
    }
}

/// Eq. 2 of Wang et al. 2009 with Eq. 10's inverse weights, computed here in f64 from the
/// geometry: with alpha = 0.4, the centroids facing up score 0.4 d (0.4, 0.8, 1.6, 3.2) and the one
/// at 0.5 facing (0.6, 0.8, 0) scores 0.2 + sqrt(2 - 1.6) = 0.832: Eq. 2 takes it third, where
/// Eq. 7 rules it out (cos 0.8 < n_t). The weights are the normalised inverse errors.
#[test]
fn eq_2_of_wang_et_al_on_a_hand_checked_point() {
    let alpha = 0.4f64;
    let Some(both) = assign_both(
        FuzzyMode::Weighted,
        Vec3::new(0.6, 0.8, 0.0),
        Metric::Ward { alpha: alpha as f32 },
    ) else {
        return;
    };
    let errors = [alpha, 2.0 * alpha, 0.5 * alpha + (2.0f64 - 2.0 * 0.8).sqrt()];
    let total: f64 = errors.iter().map(|e| 1.0 / e).sum();
    for (name, (labels, weights)) in ["CPU", "GPU"].iter().zip(both) {
        println!("{name}: labels {labels:?}, weights {weights:?}");
        assert_eq!(labels, [0, 1, 3], "{name}: Eq. 2 ranks the tilted centroid at 0.5 third");
        for (w, e) in weights.iter().zip(errors) {
            let expected = (1.0 / e / total) as f32;
            assert!((w - expected).abs() <= 1e-6, "{name}: weights {weights:?}, expected inverse Eq. 2 errors {expected} for error {e}");
        }
    }
}

/// Eq. 8: the plain mean, 1/F for each of the F clusters.
#[test]
fn eq_8_on_a_hand_checked_point() {
    let Some(both) = assign_both(FuzzyMode::Average, tilted_60(), eq7(N_T)) else { return };
    for (name, (labels, weights)) in ["CPU", "GPU"].iter().zip(both) {
        println!("{name}: labels {labels:?}, weights {weights:?}");
        assert_eq!(labels, [0, 1, 2], "{name}");
        assert!(
            weights.iter().all(|w| (w - 1.0 / 3.0).abs() <= 1e-6),
            "{name}: Eq. 8 weights {weights:?}, expected 1/3 each"
        );
    }
}

/// The indirect light of one VPL light at the shading points `sps` (no light in the scene, so
/// the pixels hold nothing else), on the CPU (`shade::indirect`) and on the GPU (the shade
/// kernel), with fuzzy visibility: shading point i reads the `f` labels and weights of row
/// `row_of[i]`, whose clusters see the light where `matrix` says so. The GPU takes the
/// exact-shape pipeline when the light is an exact disk or a polygon (whose `outline` it is).
fn one_light_on_both_backends(
    gpu: &vplgi_tests::SharedGpu,
    sps: &[ShadingPoint],
    light: VplLight,
    outline: Option<vplgi_types::LightOutline>,
    (matrix, row_of, labels, weights, f): (&BitMatrix, &[u32], &[u32], &[f32], u32),
    g_max: f32,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let set = vplgi_cpu::shade::VplLights {
        lights: vec![light],
        outlines: outline.into_iter().collect(),
    };
    let lights = LightArrays::new(&set, &[]);
    let vis = VisibilitySource::Fuzzy { matrix, row_of, labels, weights, f: f as usize };
    let cpu =
        sps.iter().enumerate().map(|(i, sp)| indirect(&[], sp, i, &lights, &vis, g_max)).collect();
    let mut scene = vplgi_scene::cornell::plane_with_point_light(4.0, 1.0, 0.5, 1.0);
    scene.lights.clear();
    let n = sps.len();
    let gpu_pixels = vplgi_tests::with_twins(gpu, &scene, |t| {
        let (device, queue) = (t.device(), t.queue());
        let (sb, rb) = (storage(device, "sps", sps), storage(device, "row_of", row_of));
        let words = storage(device, "words", bytemuck::cast_slice::<u64, u32>(matrix.words()));
        let (lb, wb, lights) = (
            storage(device, "labels", labels),
            storage(device, "weights", weights),
            storage(device, "lights", &[light]),
        );
        let outline_buf = outline.map(|o| storage(device, "light outlines", &[o]));
        let inputs = ShadeInputs {
            sps: &sb,
            sp_first: 0,
            row_of: &rb,
            words: &words,
            words_per_row: words_per_row(1) as u32,
            vpl_lights: &lights,
            outlines: outline_buf.as_ref(),
            light_count: 1,
            exact_shapes: light.exact != 0,
            lobes: None,
            visibility: Visibility::Fuzzy {
                labels: &lb,
                weights: &wb,
                f,
                window: vplgi_gpu::buffers::Window { first: 0, count: n as u64 },
            },
        };
        let params = ShadeParams { spp: 1, seed: 1, direct_samples: 1, g_max, direct: true };
        let out = t
            .gpu
            .kernels()
            .shade
            .run(device, queue, t.gpu.scene(), &inputs, 0..n as u32, &params)
            .expect("shade");
        read_back::<[f32; 4]>(device, queue, &out, n).expect("read back")
    });
    (cpu, gpu_pixels.iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect())
}

/// Eq. 6 with Eq. 9 on one shading point, both backends: one VPL of flux Φ at height h above a
/// plane, facing down; the point at horizontal distance r sees it with G = cos θ_p cos θ_v / d²
/// = h² / d⁴, clamped at g_max (the geometry-term clamp), and reflects Φ/π · ρ/π · G · Ṽ, where
/// Ṽ = Σ w_f V(p_f, p_c) over the point's three shading-point clusters (Eq. 9): with weights
/// (0.5, 0.3, 0.2) and only the second cluster blocked, Ṽ = 0.7.
///
/// The same light as a disk of radius R (Prutkin et al. 2012): its flux leaves the area A = π R²
/// with radiance Φ / (π A), so the irradiance is Φ / A times the form factor, which on the
/// disk's axis is exactly R² / (R² + h²), and off the axis Eq. 2's A cos θ_p cos θ_c / (A +
/// π d²); no clamp applies.
#[test]
fn eq_6_eq_9_and_the_clamp_on_hand_checked_points() {
    let Some(gpu) = vplgi_tests::shared_gpu("eq_6_eq_9_and_the_clamp_on_hand_checked_points")
    else {
        return;
    };
    let (h, rho) = (0.8f32, 0.5f32);
    let flux = Vec3::new(2.0, 1.0, 0.5);
    let point = VplLight::new(Vec3::new(0.0, h, 0.0), -Vec3::Y, flux);
    let rs = [0.0f32, 0.3, 1.0, 2.5];
    let sps: Vec<ShadingPoint> = rs
        .iter()
        .enumerate()
        .map(|(i, &r)| ShadingPoint {
            position: [r, 0.0, 0.0],
            normal: [0.0, 1.0, 0.0],
            albedo: [rho; 3],
            pixel: i as u32,
            ..Default::default()
        })
        .collect();
    // Three shading-point clusters; the light is visible from the first and third.
    let mut matrix = BitMatrix::new(3, 1);
    matrix.set(0, 0);
    matrix.set(2, 0);
    let labels: Vec<u32> = rs.iter().flat_map(|_| [0u32, 1, 2]).collect();
    let weights: Vec<f32> = rs.iter().flat_map(|_| [0.5f32, 0.3, 0.2]).collect();
    let row_of: Vec<u32> = (0..rs.len() as u32).collect();
    let radius = 0.6f32;
    let disk = VplLight { radius2: radius * radius, ..point };
    for (light, g_max) in
        [(point, f32::INFINITY), (point, 1.0 / (4.0 * h * h)), (disk, 1.0 / (4.0 * h * h))]
    {
        let expected: Vec<Vec3> = rs
            .iter()
            .map(|&r| {
                let d2 = h * h + r * r;
                if light.radius2 == 0.0 {
                    return flux * (rho / PI) * ((h * h / d2) / d2).min(g_max) * 0.7 / PI;
                }
                let area = PI * radius * radius;
                let form_factor = if r == 0.0 {
                    radius * radius / (radius * radius + h * h)
                } else {
                    area * (h * h / d2) / (area + PI * d2)
                };
                (rho / PI) * flux / area * form_factor * 0.7
            })
            .collect();
        let (cpu, gpu_pixels) = one_light_on_both_backends(
            gpu,
            &sps,
            light,
            None,
            (&matrix, &row_of, &labels, &weights, 3),
            g_max,
        );
        for (i, e) in expected.iter().enumerate() {
            let g = gpu_pixels[i];
            println!(
                "R² {}, g_max {g_max}, r = {}: expected {e}, CPU {}, GPU {g}",
                light.radius2, rs[i], cpu[i]
            );
            assert!(
                (cpu[i] - *e).abs().max_element() <= 1e-6 * e.max_element(),
                "CPU: r = {}: {} vs {e}",
                rs[i],
                cpu[i]
            );
            assert!(
                (g - *e).abs().max_element() <= 1e-6 * e.max_element(),
                "GPU: r = {}: {g} vs {e}",
                rs[i]
            );
        }
    }
}

/// ∫_disk cos θ_p cos θ_z / (π d²) dA for the disk of radius `r` at `centre` facing `normal`, seen
/// from `p` with normal `np`, the part below p's horizon left out: the midpoint rule in polar
/// coordinates, in double precision (the independent side of the exact disk's test).
fn disk_form_factor_by_quadrature(
    p: [f64; 3],
    np: [f64; 3],
    centre: [f64; 3],
    normal: [f64; 3],
    r: f64,
) -> f64 {
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    };
    let unit = |a: [f64; 3]| {
        let l = dot(a, a).sqrt();
        [a[0] / l, a[1] / l, a[2] / l]
    };
    let e1 =
        unit(cross(normal, if normal[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] }));
    let e2 = cross(normal, e1);
    let (nr, nphi) = (1000, 2000);
    let mut sum = 0.0;
    for i in 0..nr {
        let rho = (i as f64 + 0.5) / nr as f64 * r;
        for j in 0..nphi {
            let phi = (j as f64 + 0.5) / nphi as f64 * 2.0 * std::f64::consts::PI;
            let (c, s) = (rho * phi.cos(), rho * phi.sin());
            let d = [0, 1, 2].map(|a| centre[a] + c * e1[a] + s * e2[a] - p[a]);
            let d2 = dot(d, d);
            let (cos_p, cos_z) = (dot(np, d) / d2.sqrt(), -dot(normal, d) / d2.sqrt());
            if cos_p > 0.0 && cos_z > 0.0 {
                sum += cos_p * cos_z / (std::f64::consts::PI * d2) * rho;
            }
        }
    }
    sum * (r / nr as f64) * (2.0 * std::f64::consts::PI / nphi as f64)
}

/// A disk light lit by its exact form factor (`--light-shape disk-exact`) on both backends:
/// the irradiance Φ / A times the form factor, the form factor by quadrature over the disk. The
/// receivers lie on its axis, off it, on a wall beside the disk and on walls whose horizon cuts
/// the disk (as in a room's corners), and tilted.
#[test]
fn exact_disk_lights_give_the_form_factor_on_both_backends() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("exact_disk_lights_give_the_form_factor_on_both_backends")
    else {
        return;
    };
    let (radius, rho) = (0.6f32, 0.5f32);
    let flux = Vec3::new(2.0, 1.0, 0.5);
    let light = VplLight {
        radius2: radius * radius,
        exact: vplgi_types::pod::EXACT_DISK,
        ..VplLight::new(Vec3::new(0.0, 1.0, 0.0), -Vec3::Y, flux)
    };
    let receivers: [([f32; 3], [f32; 3]); 7] = [
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.5, 0.2, 0.3], [0.0, 1.0, 0.0]),
        ([0.7, 0.8, 0.0], [-1.0, 0.0, 0.0]),
        ([0.3, 0.9, 0.1], [-1.0, 0.0, 0.0]),
        ([-0.2, 0.85, -0.45], [0.0, 0.0, 1.0]),
        ([-0.2, 0.5, 0.4], [0.577_350_3, 0.577_350_3, -0.577_350_3]),
        ([0.1, 0.05, -0.2], [0.282_216_3, 0.940_720_9, -0.188_144_2]),
    ];
    let form_factor = |p: glam::DVec3, n: glam::DVec3| {
        disk_form_factor_by_quadrature(
            p.to_array(),
            n.to_array(),
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            radius as f64,
        )
    };
    area_light_matches_quadrature(gpu, light, None, rho, &receivers, form_factor);
}

/// The exact disk of a light that faces no coordinate axis, seen from its axis (and 1e-6 off
/// it) by receivers whose horizon cuts it. There `p − c − normal h` is rounding residue, along
/// the normal as much as in the disk's plane; a frame built on it gave 13 % too much light.
#[test]
fn exact_disk_lights_are_right_on_a_tilted_axis_on_both_backends() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("exact_disk_lights_are_right_on_a_tilted_axis_on_both_backends")
    else {
        return;
    };
    let (radius, rho) = (0.6f32, 0.5f32);
    let (centre, normal) = (Vec3::new(0.25, 1.0, 0.125), Vec3::new(0.3, -0.8, 0.2).normalize());
    let light = VplLight {
        radius2: radius * radius,
        exact: vplgi_types::pod::EXACT_DISK,
        ..VplLight::new(centre, normal, Vec3::new(2.0, 1.0, 0.5))
    };
    let t = normal.cross(Vec3::X).normalize();
    let b = normal.cross(t);
    let receivers: Vec<([f32; 3], [f32; 3])> =
        [(0.5f32, 0.0f32, 1.0f32), (0.5, 1e-6, 1.0), (0.3, 0.0, 2.0), (0.8, 1e-6, 1.5)]
            .iter()
            .map(|&(h, off, tilt)| {
                (
                    (centre + normal * h + b * (off * h)).to_array(),
                    (-normal + t * tilt).normalize().to_array(),
                )
            })
            .collect();
    let form_factor = |p: glam::DVec3, n: glam::DVec3| {
        disk_form_factor_by_quadrature(
            p.to_array(),
            n.to_array(),
            centre.as_dvec3().to_array(),
            normal.as_dvec3().to_array(),
            radius as f64,
        )
    };
    area_light_matches_quadrature(gpu, light, None, rho, &receivers, form_factor);
}

/// An exact disk emits from its front only: receivers behind its plane get no light on either
/// backend, whether the whole disk is above their horizon, their horizon cuts it, or it is below
/// it, and neither does a receiver exactly in its plane, on the disk and facing the side it
/// lights (cos θ_light = 0 over the whole disk, where the whole-disk closed form alone gives
/// 1 / R²). A receiver in front of each disk (the control) gets some. (Each backend sorts disks
/// into wholly above the horizon, cut by it, or below it before the exact form.)
#[test]
fn exact_disks_send_no_light_behind_or_beside_themselves_on_both_backends() {
    let Some(gpu) = vplgi_tests::shared_gpu(
        "exact_disks_send_no_light_behind_or_beside_themselves_on_both_backends",
    ) else {
        return;
    };
    let disk = |centre: Vec3, normal: Vec3| VplLight {
        radius2: 0.36,
        exact: vplgi_types::pod::EXACT_DISK,
        ..VplLight::new(centre, normal, Vec3::new(2.0, 1.0, 0.5))
    };
    let (centre, normal) = (Vec3::new(0.25, 1.0, 0.125), Vec3::new(0.3, -0.8, 0.2).normalize());
    let t = normal.cross(Vec3::X).normalize();
    let at = |h: f32, off: f32| centre + normal * h + t * off;
    // Behind facing the disk's back (the whole disk above the horizon), behind and tilted (the
    // horizon cuts it), behind facing away; then the control in front. `true`: must be lit.
    let tilted = [
        (at(-0.5, 0.0), normal, false),
        (at(-0.3, 0.4), (normal + t * 1.5).normalize(), false),
        (at(-0.4, -0.2), -normal, false),
        (at(0.5, 0.1), -normal, true),
    ];
    // A disk facing down from y = 1: h is exactly 0 in f32 for a receiver at y = 1.
    let level_centre = Vec3::new(0.25, 1.0, 0.125);
    let level = [
        (level_centre + Vec3::new(0.1, 0.0, 0.05), Vec3::Y, false),
        (level_centre - Vec3::Y * 0.5, Vec3::Y, true),
    ];
    for (light, cases) in
        [(disk(centre, normal), &tilted[..]), (disk(level_centre, -Vec3::Y), &level[..])]
    {
        let receivers: Vec<([f32; 3], [f32; 3])> =
            cases.iter().map(|&(p, n, _)| (p.to_array(), n.to_array())).collect();
        let (cpu, gpu_pixels) = receivers_of_one_visible_light(gpu, light, None, 0.5, &receivers);
        for (i, &(p, _, lit)) in cases.iter().enumerate() {
            let h = Vec3::from(light.normal).dot(p - Vec3::from(light.position));
            println!(
                "receiver at {p} (height {h:.3} over the disk): CPU {}, GPU {}",
                cpu[i], gpu_pixels[i]
            );
            if lit {
                assert!(
                    cpu[i].min_element() > 0.0 && gpu_pixels[i].min_element() > 0.0,
                    "the control at {p} must be lit"
                );
            } else {
                assert_eq!(
                    (cpu[i], gpu_pixels[i]),
                    (Vec3::ZERO, Vec3::ZERO),
                    "receiver at {p}, height {h} over the disk, is lit"
                );
            }
        }
    }
}

/// A polygon light (`--light-shape polygon`) on both backends: the irradiance Φ / A times the
/// form factor, the form factor by a midpoint rule over the polygon in f64 (a point-in-polygon
/// test per cell: nothing of the contour form). The polygon is a 1.2 x 0.8 rectangle with a
/// corner cut, facing down from y = 1; receivers on its axis, off it, on walls whose horizon
/// cuts it, and tilted.
#[test]
fn polygon_lights_give_the_form_factor_on_both_backends() {
    let Some(gpu) = vplgi_tests::shared_gpu("polygon_lights_give_the_form_factor_on_both_backends")
    else {
        return;
    };
    let rho = 0.5f32;
    let flux = Vec3::new(2.0, 1.0, 0.5);
    let (centre, normal) = (Vec3::new(0.0, 1.0, 0.0), -Vec3::Y);
    // Supports in the light's plane frame: +-0.6 along t, +-0.4 along b, one corner cut.
    let outline = vplgi_shared::polygon::Outline::new(&[0.6, 0.5, 0.4, 9.0, 0.6, 9.0, 0.4, 9.0]);
    assert_eq!(outline.count, 5);
    let area = outline.area();
    let placed = outline.light_outline(centre, normal);
    let light = VplLight {
        radius2: area / PI,
        exact: vplgi_types::pod::EXACT_POLYGON,
        ..VplLight::new(centre, normal, flux)
    };
    let receivers: [([f32; 3], [f32; 3]); 6] = [
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.5, 0.2, 0.3], [0.0, 1.0, 0.0]),
        ([0.3, 0.9, 0.1], [-1.0, 0.0, 0.0]),
        ([-0.2, 0.85, -0.25], [0.0, 0.0, 1.0]),
        ([-0.2, 0.5, 0.4], [0.577_350_3, 0.577_350_3, -0.577_350_3]),
        ([0.1, 0.05, -0.2], [0.282_216_3, 0.940_720_9, -0.188_144_2]),
    ];
    let corners: Vec<glam::DVec3> = outline.placed(centre, normal).map(|v| v.as_dvec3()).collect();
    let form_factor = |p: glam::DVec3, n: glam::DVec3| {
        polygon_form_factor_by_quadrature(p, n, &corners, normal.as_dvec3())
    };
    area_light_matches_quadrature(gpu, light, Some(placed), rho, &receivers, form_factor);
}

/// The polygon of [`polygon_lights_give_the_form_factor_on_both_backends`] facing no coordinate
/// axis (the tilted disk's normal), on both backends against the same midpoint rule over its
/// placed corners in f64: the outline's frame and every corner mix all three axes. Receivers on
/// its axis facing it, on it and 1e-6 off it with their horizon through the polygon, and off the
/// axis. The rule shares only the placed corners with the backends, nothing of their contour
/// sums.
#[test]
fn polygon_lights_are_right_on_a_tilted_axis_on_both_backends() {
    let Some(gpu) =
        vplgi_tests::shared_gpu("polygon_lights_are_right_on_a_tilted_axis_on_both_backends")
    else {
        return;
    };
    let rho = 0.5f32;
    let (centre, normal) = (Vec3::new(0.25, 1.0, 0.125), Vec3::new(0.3, -0.8, 0.2).normalize());
    let outline = vplgi_shared::polygon::Outline::new(&[0.6, 0.5, 0.4, 9.0, 0.6, 9.0, 0.4, 9.0]);
    assert_eq!(outline.count, 5);
    let area = outline.area();
    let placed = outline.light_outline(centre, normal);
    let light = VplLight {
        radius2: area / PI,
        exact: vplgi_types::pod::EXACT_POLYGON,
        ..VplLight::new(centre, normal, Vec3::new(2.0, 1.0, 0.5))
    };
    // (height over the plane, offset along b as a share of the height, tilt of the receiver's
    // normal toward t): a tilt k puts its horizon at k s + h = 0, s along t, inside ±0.6.
    let (t, b) = vplgi_shared::polygon::frame(normal);
    let receivers: Vec<([f32; 3], [f32; 3])> = [
        (0.5f32, 0.0f32, 0.0f32),
        (0.5, 0.0, 1.0),
        (0.5, 1e-6, 1.0),
        (0.3, 0.0, 2.0),
        (0.8, 1e-6, 1.5),
        (0.4, 0.75, 0.3),
    ]
    .iter()
    .map(|&(h, off, tilt)| {
        (
            (centre + normal * h + b * (off * h)).to_array(),
            (-normal + t * tilt).normalize().to_array(),
        )
    })
    .collect();
    let corners: Vec<glam::DVec3> = outline.placed(centre, normal).map(|v| v.as_dvec3()).collect();
    let form_factor = |p: glam::DVec3, n: glam::DVec3| {
        polygon_form_factor_by_quadrature(p, n, &corners, normal.as_dvec3())
    };
    area_light_matches_quadrature(gpu, light, Some(placed), rho, &receivers, form_factor);
}

/// Receivers (position, normal; albedo `rho`) that all see `light` unoccluded and unclamped: their
/// radiance on both backends.
fn receivers_of_one_visible_light(
    gpu: &vplgi_tests::SharedGpu,
    light: VplLight,
    outline: Option<vplgi_types::LightOutline>,
    rho: f32,
    receivers: &[([f32; 3], [f32; 3])],
) -> (Vec<Vec3>, Vec<Vec3>) {
    let sps: Vec<ShadingPoint> = receivers
        .iter()
        .enumerate()
        .map(|(i, &(p, n))| ShadingPoint {
            position: p,
            normal: n,
            albedo: [rho; 3],
            pixel: i as u32,
            ..Default::default()
        })
        .collect();
    let mut matrix = BitMatrix::new(1, 1);
    matrix.set(0, 0);
    let (labels, weights, row_of) =
        (vec![0u32; sps.len()], vec![1.0f32; sps.len()], vec![0u32; sps.len()]);
    one_light_on_both_backends(
        gpu,
        &sps,
        light,
        outline,
        (&matrix, &row_of, &labels, &weights, 1),
        f32::INFINITY,
    )
}

/// One area light (a polygon if it has an `outline`, else a disk) over `receivers` (position,
/// normal; albedo `rho`) on both backends, each pixel against the irradiance Φ / A times
/// `form_factor(p, n)` (a quadrature) within 2e-4 of its size, A = π `light.radius2`; every
/// receiver must see some of the light, or the case is useless.
fn area_light_matches_quadrature(
    gpu: &vplgi_tests::SharedGpu,
    light: VplLight,
    outline: Option<vplgi_types::LightOutline>,
    rho: f32,
    receivers: &[([f32; 3], [f32; 3])],
    form_factor: impl Fn(glam::DVec3, glam::DVec3) -> f64,
) {
    let shape = if outline.is_some() { "polygon" } else { "disk" };
    let area = PI * light.radius2;
    let flux = Vec3::from(light.flux);
    let (cpu, gpu_pixels) = receivers_of_one_visible_light(gpu, light, outline, rho, receivers);
    for (i, &(p, n)) in receivers.iter().enumerate() {
        let e = (rho / PI) * flux / area
            * form_factor(Vec3::from(p).as_dvec3(), Vec3::from(n).as_dvec3()) as f32;
        let (c, g) = (cpu[i], gpu_pixels[i]);
        println!("{shape}, receiver {:?}: quadrature {e}, CPU {c}, GPU {g}", receivers[i]);
        assert!(e.max_element() > 0.0, "receiver {i} sees none of the {shape}: a useless case");
        assert!(
            (c - e).abs().max_element() <= 2e-4 * e.max_element(),
            "CPU: {shape}, receiver {:?}: {c} vs {e}",
            receivers[i]
        );
        assert!(
            (g - e).abs().max_element() <= 2e-4 * e.max_element(),
            "GPU: {shape}, receiver {:?}: {g} vs {e}",
            receivers[i]
        );
    }
}

/// ∫ cos θ_p cos θ_z / (π d²) dA over the convex polygon `corners` (counterclockwise about
/// `normal`, which it faces) seen from `p` with normal `np`, the part below p's horizon left
/// out: the midpoint rule on a 2,000 x 2,000 grid over its bounding box in the plane.
fn polygon_form_factor_by_quadrature(
    p: glam::DVec3,
    np: glam::DVec3,
    corners: &[glam::DVec3],
    normal: glam::DVec3,
) -> f64 {
    let e1 = (corners[1] - corners[0]).normalize();
    let e2 = normal.cross(e1);
    let o = corners[0];
    let (lo, hi) = corners.iter().fold(
        (glam::DVec2::splat(f64::MAX), glam::DVec2::splat(f64::MIN)),
        |(lo, hi), c| {
            let q = glam::DVec2::new((*c - o).dot(e1), (*c - o).dot(e2));
            (lo.min(q), hi.max(q))
        },
    );
    let inside = |x: glam::DVec3| {
        (0..corners.len()).all(|i| {
            normal.dot((corners[(i + 1) % corners.len()] - corners[i]).cross(x - corners[i])) >= 0.0
        })
    };
    let cells = 2000;
    let (w, h) = ((hi.x - lo.x) / cells as f64, (hi.y - lo.y) / cells as f64);
    let mut sum = 0.0;
    for i in 0..cells {
        for j in 0..cells {
            let x = o + e1 * (lo.x + (i as f64 + 0.5) * w) + e2 * (lo.y + (j as f64 + 0.5) * h);
            if !inside(x) {
                continue;
            }
            let d = x - p;
            let d2 = d.length_squared();
            let (cos_p, cos_z) = (np.dot(d) / d2.sqrt(), -normal.dot(d) / d2.sqrt());
            if cos_p > 0.0 && cos_z > 0.0 {
                sum += cos_p * cos_z / (std::f64::consts::PI * d2);
            }
        }
    }
    sum * w * h
}

/// Alg. 1's update: a centroid is the mean of its members' positions (and its normal their
/// normalised mean). Two separated blobs of 50 points, K = 2: after the iterations each centroid
/// is its blob's mean, computed here in f64, on both backends (whose sums are fixed-point: within
/// 1e-6 of the data's extent).
#[test]
fn alg_1_centroids_are_the_means_of_their_members() {
    let Some(gpu) = vplgi_tests::shared_gpu("alg_1_centroids_are_the_means_of_their_members")
    else {
        return;
    };
    let mut rng = vplgi_types::Rng::new(3, vplgi_types::Stream::Oracle, 0);
    let mut ps = Vec::new();
    for centre in [Vec3::new(-5.0, 0.0, 0.0), Vec3::new(5.0, 1.0, 0.0)] {
        for _ in 0..50 {
            ps.push(centre + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5);
        }
    }
    let ns = vec![Vec3::Y; ps.len()];
    let mean = |half: &[Vec3]| {
        half.iter().fold(glam::DVec3::ZERO, |a, p| a + p.as_dvec3()) / half.len() as f64
    };
    let expected = [mean(&ps[..50]), mean(&ps[50..])];
    let params = vplgi_types::clustering::ClusterParams {
        k: 2,
        gamma: 1,
        iterations: 4,
        f: 1,
        fuzzy: FuzzyMode::Hard,
        metric: vplgi_types::clustering::Metric::Eq7 { normal_threshold: 0.866 },
        representative: vplgi_types::clustering::Representative::Nearest,
        seed: 1,
    };
    let cpu = vplgi_cpu::cluster::cluster(&ps, &ns, &params);
    let (device, queue) = (&gpu.ctx.device, &gpu.ctx.queue);
    let pts = storage(
        device,
        "points",
        &ps.iter().zip(&ns).map(|(&p, &n)| Endpoint::new(p, n)).collect::<Vec<_>>(),
    );
    let g = gpu
        .kernels
        .cluster
        .cluster(device, queue, &pts, ps.len() as u32, &params)
        .expect("cluster");
    let gc: Vec<Endpoint> =
        read_back(device, queue, &g.centroids, g.k as usize).expect("centroids");
    let gpu_centroids: Vec<Vec3> = gc.iter().map(Endpoint::p).collect();
    let extent = 11.0;
    for (name, mut got) in [("CPU", cpu.positions.clone()), ("GPU", gpu_centroids)] {
        got.sort_by(|a, b| a.x.total_cmp(&b.x));
        println!("{name}: centroids {got:?}, expected {expected:?}");
        assert_eq!(got.len(), 2, "{name}");
        for (c, e) in got.iter().zip(&expected) {
            assert!(
                (c.as_dvec3() - *e).abs().max_element() <= 1e-6 * extent,
                "{name}: centroid {c} is not its members' mean {e}"
            );
        }
    }
}
