//! Inputs the differential tests share: fixed point sets from real scenes, and proptest
//! strategies for random ones.

use glam::Vec3;
use proptest::prelude::*;
use vplgi_cpu::CpuScene;
use vplgi_scene::cornell::cornell_box;

/// The Cornell box's shading points (surfaces meeting at edges, both orientations of thin walls)
/// at `width` x `height`, one per pixel: positions and normals of the hits.
pub fn cornell_points(width: u32, height: u32, seed: u32) -> (Vec<Vec3>, Vec<Vec3>) {
    let scene = cornell_box();
    let device = vplgi_embree::Device::new(None).expect("Embree device");
    let cs = CpuScene::new(&scene, &device).expect("Embree scene");
    let sps = vplgi_cpu::shading_points::shading_points(&cs, width, height, 1, seed);
    sps.iter().filter(|s| !s.is_miss()).map(|s| (Vec3::from(s.position), Vec3::from(s.normal))).unzip()
}

/// A unit vector from two numbers in [0, 1).
fn direction(u: f32, v: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Surface-like point sets, as clustering sees them: 1 to 6 planar patches of random orientation,
/// size and offset, with 100 to 1,500 points in all, some patches seen from both sides (normals
/// flipped at random per point), at a random scale of the scene (1e-2 to 1e2).
pub fn surface_points() -> impl Strategy<Value = (Vec<Vec3>, Vec<Vec3>)> {
    let patch = (0f32..1.0, 0f32..1.0, 0f32..1.0, 0f32..1.0, -1f32..1.0, -1f32..1.0, -1f32..1.0, 0.05f32..1.0, any::<bool>());
    (prop::collection::vec(patch, 1..=6), 100usize..1500, -2f32..2.0, any::<u64>()).prop_map(|(patches, n, log_scale, seed)| {
        let scale = 10f32.powf(log_scale);
        let mut rng = vplgi_types::Rng::new(seed as u32, vplgi_types::Stream::Oracle, (seed >> 32) as u32);
        let (mut ps, mut ns) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for i in 0..n {
            let (nu, nv, tu, tv, ox, oy, oz, size, two_sided) = patches[i % patches.len()];
            let normal = direction(nu, nv);
            let tangent = normal.cross(direction(tu, tv)).try_normalize().unwrap_or(normal.any_orthonormal_vector());
            let bitangent = normal.cross(tangent);
            let (a, b) = (rng.next_f32() - 0.5, rng.next_f32() - 0.5);
            let p = Vec3::new(ox, oy, oz) + (tangent * a + bitangent * b) * size;
            let flip = two_sided && rng.next_f32() < 0.5;
            ps.push(p * scale);
            ns.push(if flip { -normal } else { normal });
        }
        (ps, ns)
    })
}
