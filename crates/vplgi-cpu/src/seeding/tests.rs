use super::*;
use vplgi_types::{Rng, Stream};

/// A synthetic image of `w x h` pixels with `spp` hits each (pixel order), except pixels where
/// `hole(x, y)`: the left half a flat floor (one normal, positions on a plane), the right half
/// a bumpy surface whose normals turn from pixel to pixel.
fn image(w: u32, h: u32, spp: u32, hole: impl Fn(u32, u32) -> bool) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let mut rng = Rng::new(3, Stream::Oracle, 9);
    let (mut ps, mut ns, mut first) = (Vec::new(), Vec::new(), vec![0u32]);
    for y in 0..h {
        for x in 0..w {
            if !hole(x, y) {
                for _ in 0..spp {
                    let (u, v) = (x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                    if x < w / 2 {
                        ps.push(Vec3::new(u, 0.0, v) * 0.01);
                        ns.push(Vec3::Y);
                    } else {
                        let t = (u * 0.9).sin() * (v * 0.7).cos();
                        ps.push(Vec3::new(u, 0.3 * t, v) * 0.01);
                        ns.push(Vec3::new(-0.8 * t, 1.0, 0.5 * (v * 1.3).sin()).normalize());
                    }
                }
            }
            first.push(ps.len() as u32);
        }
    }
    (ps, ns, first)
}

fn seeds_of(ps: &[Vec3], ns: &[Vec3], first: &[u32], (w, h): (u32, u32), k: u32, seed: u32) -> Vec<u32> {
    let hits = ImageHits { positions: ps, normals: ns, pixel_first: first, width: w, height: h };
    seeding(&hits, &SeedParams { k, alpha: 2.0, seed })
}

/// The pixel of hit `i`.
fn pixel_of(first: &[u32], i: u32) -> u32 {
    (first.partition_point(|&f| f <= i) - 1) as u32
}

/// The root's four quadrants get their seeds in proportion to their Eq. 2 variation, computed
/// here directly in f64 from the hits whose pixels lie in each quadrant (mean position, mean
/// normal, summed errors): each quadrant's seed count is within one of K ε_q / Σ ε. The bumpy
/// right half gets most of them; every seed is a distinct hit.
#[test]
fn quadrants_get_seeds_in_proportion_to_their_variation() {
    let (w, h) = (64u32, 48u32);
    let (ps, ns, first) = image(w, h, 1, |x, y| (x + 3 * y) % 17 == 0);
    let k = 300;
    let seeds = seeds_of(&ps, &ns, &first, (w, h), k, 5);
    assert_eq!(seeds.len(), k as usize, "no quadtree node saturates here");
    let mut sorted = seeds.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), seeds.len(), "seeds are distinct hits");
    // The padded square is 64 x 64: quadrants of 32 x 32 pixels.
    let quadrant = |p: u32| ((p % w) / 32 + 2 * ((p / w) / 32)) as usize;
    let mut variation = [0f64; 4];
    for (qd, v) in variation.iter_mut().enumerate() {
        let members: Vec<usize> = (0..ps.len()).filter(|&i| quadrant(pixel_of(&first, i as u32)) == qd).collect();
        if members.is_empty() {
            continue;
        }
        let n = members.len() as f64;
        let mean = members.iter().fold(glam::DVec3::ZERO, |a, &i| a + ps[i].as_dvec3()) / n;
        let nrm = members.iter().fold(glam::DVec3::ZERO, |a, &i| a + ns[i].as_dvec3()).normalize();
        *v = members.iter().map(|&i| 2.0 * (ps[i].as_dvec3() - mean).length() + (2.0 - 2.0 * ns[i].as_dvec3().dot(nrm)).max(0.0).sqrt()).sum();
    }
    let total: f64 = variation.iter().sum();
    let mut counts = [0usize; 4];
    for &s in &seeds {
        counts[quadrant(pixel_of(&first, s))] += 1;
    }
    for qd in 0..4 {
        let expected = k as f64 * variation[qd] / total;
        println!("quadrant {qd}: variation {:.3}, {} seeds, expected {expected:.2}", variation[qd], counts[qd]);
        assert!((counts[qd] as f64 - expected).abs() <= 1.0 + 1e-3 * expected, "quadrant {qd}: {} seeds, expected {expected:.2}", counts[qd]);
    }
    assert!(counts[1] + counts[3] > 2 * (counts[0] + counts[2]), "the bumpy half must get most seeds: {counts:?}");
}

/// More seeds than hits: every hit is a seed, once. A node given one seed picks one of its
/// hits at random: different seeds of the RNG pick differently, the same seed the same.
#[test]
fn saturated_and_single_seed_nodes() {
    let (w, h) = (6u32, 5u32);
    let (ps, ns, first) = image(w, h, 2, |x, _| x == 0);
    let all = seeds_of(&ps, &ns, &first, (w, h), 1000, 1);
    let mut sorted = all.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..ps.len() as u32).collect::<Vec<_>>(), "K above the hit count seeds every hit once");
    let one: Vec<Vec<u32>> = (0..8).map(|s| seeds_of(&ps, &ns, &first, (w, h), 1, s)).collect();
    assert!(one.iter().all(|v| v.len() == 1));
    assert!(one.iter().any(|v| v != &one[0]), "one seed is jittered over the image: {one:?}");
    assert_eq!(seeds_of(&ps, &ns, &first, (w, h), 1, 3), one[3]);
    // No hits, no seeds; an image of one pixel.
    assert!(seeds_of(&[], &[], &vec![0; (w * h + 1) as usize], (w, h), 10, 1).is_empty());
    assert_eq!(seeds_of(&ps[..2], &ns[..2], &[0, 2], (1, 1), 5, 1), vec![0, 1]);
}
