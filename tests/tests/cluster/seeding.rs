//! `seeding` (`--seeding adaptive`, Wang et al.'s screen-space quadtree): GPU against CPU on
//! random scenes' hits (SPEC: the same seeds in the same order), measured by `vplgi verify`'s
//! comparison; and the clustering that starts from them, whole on both backends.

use proptest::prelude::*;
use vplgi_types::FrameConfig;
use vplgi_verify::inputs::CpuFrame;

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(8))]

    /// Any image size (odd, non-square, one pixel), 1 to 3 samples per pixel, K from one to
    /// more than the samples (0.1 % to 120 % of them), alpha from 0.01 to 30 per diagonal:
    /// identical seeds, and the clustering from them meets the whole-clustering rows.
    #[test]
    fn seeding_matches_the_cpu_on_random_scenes(
        scene in vplgi_tests::inputs::random_scene(),
        (width, height, spp) in (1u32..120, 1u32..90, 1u32..=3),
        k_share in -3f32..0.08,
        log_alpha in -2f32..1.5,
        seed in any::<u32>(),
    ) {
        let Some(gpu) = vplgi_tests::shared_gpu("seeding_matches_the_cpu_on_random_scenes") else { return Ok(()) };
        let k_sp = ((width * height * spp) as f32 * 10f32.powf(k_share)).max(1.0) as u32;
        let cfg = FrameConfig { width, height, spp, k_sp, alpha: 10f32.powf(log_alpha), seed, ..FrameConfig::verify() };
        println!("{}: {width}x{height}, spp {spp}, K {k_sp}, alpha {}", scene.name, cfg.alpha);
        let checks = vplgi_tests::with_twins(gpu, &scene, |t| -> Result<_, vplgi_verify::VerifyError> {
            let frame = CpuFrame::new(t.cpu, &cfg);
            let (seeds, check) = vplgi_verify::cluster::compare_seeding(t, &frame, &cfg)?;
            let (ps, ns) = frame.hit_points();
            let expected = (k_sp as usize).min(ps.len());
            assert_eq!(seeds.len(), expected, "min(K, hits) seeds");
            let mut checks = vec![check];
            if !ps.is_empty() {
                let kernel = &t.gpu.kernels().cluster;
                checks.extend(vplgi_verify::cluster::compare_clustering(t.device(), t.queue(), kernel, (&ps, &ns), &cfg.sp_cluster_params(t.cpu.extent), vplgi_types::clustering::ClusterStart::Seeds(&seeds))?);
            }
            Ok(checks)
        }).expect("GPU");
        vplgi_tests::hold(&checks)?;
    }
}

/// The most samples per pixel the GPU seeds (`seeding::max_spp`, what a frame is refused past)
/// on an 8 x 8 image of the Cornell box: every pixel's invocation walks thousands of hits per
/// level, and the seeds are still the CPU's.
#[test]
fn seeding_at_its_largest_spp_matches_the_cpu() {
    let Some(gpu) = vplgi_tests::shared_gpu("seeding_at_its_largest_spp_matches_the_cpu") else {
        return;
    };
    let (width, height) = (8, 8);
    let spp =
        vplgi_shared::seeding::max_spp(vplgi_shared::seeding::Quadtree::new(width, height).levels);
    let cfg = FrameConfig {
        width,
        height,
        spp,
        k_sp: 1_500,
        seeding: vplgi_types::Seeding::Adaptive,
        ..FrameConfig::verify()
    };
    let scene = vplgi_scene::cornell::cornell_box();
    let check = vplgi_tests::with_twins(gpu, &scene, |t| {
        vplgi_verify::cluster::compare_seeding(t, &CpuFrame::new(t.cpu, &cfg), &cfg)
    })
    .expect("GPU")
    .1;
    println!("{spp} spp: {check}");
    check.check();
}
