//! Degenerate inputs through the whole CPU pipeline: no crash, and the obvious answer.

use vplgi_cpu::{CpuScene, NoProgress};
use vplgi_scene::cornell::cornell_box;
use vplgi_types::{ClusterMode, FrameConfig, FuzzyMode};

const MODES: [ClusterMode; 4] =
    [ClusterMode::None, ClusterMode::Sp, ClusterMode::Vpl, ClusterMode::Both];

/// With 0 VPLs every mode renders exactly the direct-only image.
#[test]
fn zero_vpls_gives_direct_light_only_in_every_mode() {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let base = FrameConfig {
        width: 20,
        height: 20,
        vpls: 0,
        k_sp: 50,
        k_vpl: 10,
        ..FrameConfig::reference()
    };
    let reference = vplgi_cpu::render(&cs, &base, &NoProgress).unwrap();
    assert!(reference.pixels.iter().any(|p| p[0] > 0.0), "direct light must be visible");
    for mode in MODES {
        let f = vplgi_cpu::render(&cs, &FrameConfig { cluster: mode, ..base.clone() }, &NoProgress)
            .unwrap();
        assert_eq!(f.pixels, reference.pixels, "{mode:?}");
        assert_eq!(f.stats.vpl_clusters, 0);
    }
}

/// More clusters than points, F larger than the clusters, one cluster: all valid.
#[test]
fn extreme_cluster_counts() {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    for (k_sp, k_vpl, f) in [(1, 1, 6), (10_000, 10_000, 16), (3, 500, 16)] {
        for fuzzy in [FuzzyMode::Hard, FuzzyMode::Average, FuzzyMode::Weighted] {
            let cfg = FrameConfig {
                width: 16,
                height: 16,
                vpls: 300,
                k_sp,
                k_vpl,
                f,
                fuzzy,
                cluster: ClusterMode::Both,
                ..FrameConfig::reference()
            };
            let frame = vplgi_cpu::render(&cs, &cfg, &NoProgress).unwrap();
            assert!(
                frame.stats.sp_clusters >= 1
                    && frame.stats.sp_clusters <= frame.stats.shading_point_hits.min(k_sp)
            );
            assert!(frame.stats.vpl_clusters >= 1 && frame.stats.vpl_clusters <= 300.min(k_vpl));
            assert!(frame.pixels.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
        }
    }
}

/// With as many clusters as points and F = 1, clustering changes nothing: the clustered image
/// equals the reference bit for bit (every point is its own representative).
#[test]
fn one_cluster_per_point_reproduces_the_reference() {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let base = FrameConfig {
        width: 12,
        height: 12,
        vpls: 200,
        k_sp: 1_000_000,
        k_vpl: 1_000_000,
        fuzzy: FuzzyMode::Hard,
        ..FrameConfig::reference()
    };
    let reference = vplgi_cpu::render(
        &cs,
        &FrameConfig { cluster: ClusterMode::None, ..base.clone() },
        &NoProgress,
    )
    .unwrap();
    let vpl_only = vplgi_cpu::render(
        &cs,
        &FrameConfig { cluster: ClusterMode::Vpl, ..base.clone() },
        &NoProgress,
    )
    .unwrap();
    // VPL clusters sum their members' flux in a different order than the per-VPL loop, so allow
    // rounding, but nothing more.
    for (a, b) in reference.pixels.iter().zip(&vpl_only.pixels) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-5 * a[c].max(1e-3), "{a:?} vs {b:?}");
        }
    }
    let sp_only = vplgi_cpu::render(
        &cs,
        &FrameConfig { cluster: ClusterMode::Sp, ..base.clone() },
        &NoProgress,
    )
    .unwrap();
    assert_eq!(sp_only.pixels, reference.pixels);
}

/// The library entry point refuses invalid configurations instead of dividing by zero.
#[test]
fn render_rejects_invalid_configurations() {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = CpuScene::new(&scene, &device).unwrap();
    let err =
        vplgi_cpu::render(&cs, &FrameConfig { spp: 0, ..FrameConfig::default() }, &NoProgress)
            .unwrap_err();
    assert!(err.to_string().contains("spp"), "{err}");
}

/// Non-finite attributes are rejected by scene validation (a NaN texture coordinate would
/// otherwise turn every pixel NaN through the VPL fluxes).
#[test]
fn scenes_with_non_finite_attributes_are_rejected() {
    let mut scene = cornell_box();
    scene.uvs[3].x = f32::NAN;
    assert!(scene.validate().unwrap_err().contains("texture"));
    let mut scene = cornell_box();
    scene.materials[0].emission.y = f32::INFINITY;
    assert!(scene.validate().is_err());
}

/// An unclustered frame rendered as row tiles is the whole frame, bit for bit, at 1 and 3
/// samples per pixel; a clustered frame refuses to be tiled.
#[test]
fn row_tiles_of_a_reference_equal_the_whole_frame() {
    let scene = vplgi_scene::cornell::cornell_box();
    let device = vplgi_embree::Device::new(None).unwrap();
    let cs = vplgi_cpu::CpuScene::new(&scene, &device).unwrap();
    for spp in [1, 3] {
        let cfg = vplgi_types::FrameConfig {
            width: 24,
            height: 18,
            spp,
            vpls: 300,
            cluster: vplgi_types::ClusterMode::None,
            ..Default::default()
        };
        let whole = vplgi_cpu::render(&cs, &cfg, &vplgi_cpu::NoProgress).unwrap();
        let mut tiled = Vec::new();
        for rows in [0..7, 7..8, 8..18] {
            let t =
                vplgi_cpu::render_rows(&cs, &cfg, rows.clone(), &vplgi_cpu::NoProgress).unwrap();
            assert_eq!((t.width, t.height), (24, rows.end - rows.start));
            tiled.extend(t.pixels);
        }
        assert_eq!(tiled, whole.pixels, "spp {spp}: tiles differ from the whole frame");
    }
    let clustered =
        vplgi_types::FrameConfig { width: 24, height: 18, vpls: 300, ..Default::default() };
    assert!(vplgi_cpu::render_rows(&cs, &clustered, 0..9, &vplgi_cpu::NoProgress).is_err());
}

/// The clustering grid's cell of a point is floor((p - origin) / cell), clamped into the grid: a
/// point exactly on a cell's lower face belongs to that cell, and a point on or past the grid's
/// upper face (rounding can put the data's maximum there) to the last cell, never to a cell of
/// the next row.
#[test]
fn grid_cells_are_floors_clamped_into_the_grid() {
    use glam::Vec3;
    use vplgi_cpu::cluster::{bounds, Grid};
    let data = [Vec3::ZERO, Vec3::new(4.0, 3.0, 2.0), Vec3::new(1.0, 2.5, 0.5)];
    let grid = Grid::for_data(bounds(&data), &data, 8);
    let [nx, ny, nz] = grid.dims;
    let at = |c: [f32; 3]| grid.origin + Vec3::from(c) * grid.cell;
    // On the lower face of cell (1, 1, 1): that cell, not the one below. (The origin is the data's
    // minimum, 0, so the face is exactly one cell size out and its quotient exactly 1.)
    assert!(nx > 1 && ny > 1 && nz > 1 && grid.origin == Vec3::ZERO, "grid {grid:?}");
    assert_eq!(grid.coords(at([1.0, 1.0, 1.0])), [1, 1, 1], "grid {grid:?}");
    // On the upper face of the grid and beyond it: the last cell.
    let last = [nx - 1, ny - 1, nz - 1];
    assert_eq!(grid.coords(at([nx as f32, ny as f32, nz as f32])), last);
    assert_eq!(grid.coords(at([nx as f32 + 5.0, ny as f32 + 5.0, nz as f32 + 5.0])), last);
    // Below the origin: the first cell.
    assert_eq!(grid.coords(at([-0.5, -3.0, -0.25])), [0, 0, 0]);
}
