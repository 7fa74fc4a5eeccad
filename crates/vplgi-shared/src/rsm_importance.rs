//! The bidirectional importance map of Prutkin et al. 2012 (Alg. 1, lines 1-7, after Ritschel et
//! al. 2011) and the importance warping of the RSM clustering's seeds.
//!
//! * **Importance** of a texel: how much light its VPL sends toward what the camera sees,
//!   I = (Φ_r + Φ_g + Φ_b) Σ_i G(x_v, x_i) over [`PIXELS`] G-buffer pixels on the 2-D Halton
//!   sequence, with G = max(0, n_v·ω) max(0, −n_i·ω) / max(d², d_min²) and no visibility (as in
//!   the paper: the map is a heuristic for where clusters are spent, not a light transport
//!   estimate). `d_min` ([`D_MIN_REL`] of the scene's diagonal) keeps a VPL next to one sampled
//!   pixel from taking every seed. Texels without a VPL have importance 0.
//! * **Warping**: seed j of a map is the 2-D Halton point j, moved through the map's importance
//!   by its inverse CDF: the row by the marginal CDF of the row sums at the base-3 coordinate,
//!   then the column by that row's CDF at the base-2 coordinate. Both coordinates are 20-bit
//!   binary fractions and the CDFs are sums of integers ([`quantize`]: each map's importance
//!   scaled by a power of two, so the scaling is exact; each texel capped at one seed's share,
//!   [`weight_cap`]), so every backend given the same importance picks the same texels. A map whose importance is all zero (no pixel sees its
//!   VPLs) keeps the plain Halton seeds.

use glam::Vec3;
use vplgi_types::{Endpoint, Vpl};

/// G-buffer pixels the importance is accumulated from (the paper's 256).
pub const PIXELS: u32 = 256;

/// The distance below which the geometry term of the importance stops growing, in scene
/// diagonals.
pub const D_MIN_REL: f32 = 0.01;

/// Binary digits of the Halton fractions.
pub const FRACTION_BITS: u32 = 20;

/// Point `i` of the 2-D Halton sequence (bases 2 and 3) as two 20-bit binary fractions
/// (floor(2^20 φ_2(i)), floor(2^20 φ_3(i))), in integer arithmetic only. φ_3 keeps its first 12
/// ternary digits, as `rsm::halton_texel` does.
pub fn halton_fractions(i: u32) -> (u32, u32) {
    let f2 = i.reverse_bits() >> (32 - FRACTION_BITS);
    let (mut x3, mut j) = (0u32, i);
    for _ in 0..12 {
        x3 = x3 * 3 + j % 3;
        j /= 3;
    }
    // x3 / 3^12 to 20 binary digits by long division (the remainder stays below 2 · 3^12).
    let (mut f3, mut r) = (0u32, x3);
    for _ in 0..FRACTION_BITS {
        r *= 2;
        f3 *= 2;
        if r >= 531_441 {
            r -= 531_441;
            f3 += 1;
        }
    }
    (f2, f3)
}

/// floor(f · n / 2^20) for a 20-bit fraction `f`: a point of [0, n).
pub fn scale_fraction(f: u32, n: u32) -> u32 {
    ((f as u64 * n as u64) >> FRACTION_BITS) as u32
}

/// The camera samples the importance is accumulated from: the first sample of each of the
/// [`PIXELS`] pixels at points 1..=256 of the 2-D Halton sequence over a `width` × `height`
/// image of `spp` samples per pixel. A pixel whose sample misses adds nothing.
pub fn pixel_samples(width: u32, height: u32, spp: u32) -> Vec<u32> {
    (1..=PIXELS)
        .map(|i| {
            let (fx, fy) = halton_fractions(i);
            let (x, y) = (scale_fraction(fx, width), scale_fraction(fy, height));
            (y * width + x) * spp
        })
        .collect()
}

/// One G-buffer point's share of a texel's importance: the geometry term between the VPL and
/// the point, its distance floored at `d_min` (`d_min2` = d_min²).
pub fn term(v: &Vpl, p: &Endpoint, d_min2: f32) -> f32 {
    let d = Vec3::from(p.position) - Vec3::from(v.position);
    let d2 = d.length_squared();
    if d2 <= 0.0 {
        return 0.0;
    }
    let w = d / d2.sqrt();
    let cos_v = Vec3::from(v.normal).dot(w).max(0.0);
    let cos_p = (-Vec3::from(p.normal).dot(w)).max(0.0);
    cos_v * cos_p / d2.max(d2_floor(d_min2))
}

fn d2_floor(d_min2: f32) -> f32 {
    d_min2.max(f32::MIN_POSITIVE)
}

/// The importance of VPL `v` seen from the G-buffer points `points`, summed in order.
pub fn importance(v: &Vpl, points: &[Endpoint], d_min2: f32) -> f32 {
    let g: f32 = points.iter().fold(0.0, |acc, p| acc + term(v, p, d_min2));
    (v.flux[0] + v.flux[1] + v.flux[2]) * g
}

/// Bits of a map's quantised importance: the largest texel gets at most 2^bits, so the sum of
/// `texels` of them stays below 2^31.
pub fn quantum_bits(texels: u32) -> u32 {
    let ceil_log2 = 32 - texels.saturating_sub(1).leading_zeros();
    31u32.saturating_sub(ceil_log2).min(24)
}

/// The power of two that puts a map's largest importance `max` in [2^(bits-1), 2^bits).
pub fn quantum_scale(max: f32, texels: u32) -> f32 {
    let exponent = ((max.to_bits() >> 23) & 0xff) as i32 - 127;
    let e = (quantum_bits(texels) as i32 - 1 - exponent).clamp(-126, 127);
    f32::from_bits(((e + 127) as u32) << 23)
}

/// A texel's importance as an integer weight of the warp: ceil(importance · scale), so a texel
/// with any importance keeps a chance of a seed. Exact: `scale` is a power of two.
pub fn quantize(importance: f32, scale: f32) -> u32 {
    (importance * scale).ceil() as u32
}

/// The texel (x, y) of an `n` × `n` map that warped seed point `i` lands on, given the map's
/// quantised importance `q` (n² weights, row-major) and its row sums' running totals `rows`
/// (inclusive: rows[y] = Σ_{r<=y} row sum r). `None` if the map has no importance.
pub fn warp(i: u32, n: u32, q: &[u32], rows: &[u32]) -> Option<(u32, u32)> {
    let total = *rows.last()?;
    if total == 0 {
        return None;
    }
    let (fx, fy) = halton_fractions(i);
    let target = scale_fraction(fy, total);
    let y = rows.partition_point(|&c| c <= target) as u32;
    let row_sum = rows[y as usize] - if y > 0 { rows[y as usize - 1] } else { 0 };
    let target = scale_fraction(fx, row_sum);
    let row = &q[(y * n) as usize..((y + 1) * n) as usize];
    let mut acc = 0u32;
    let x = row.iter().position(|&w| {
        acc += w;
        acc > target
    })?;
    Some((x as u32, y))
}

/// The most weight one texel of a map keeps: its share of the map's `k` seeds, total / k
/// rounded up. A texel holds one VPL, so one cluster: importance beyond one seed's share would
/// only put several seeds on it, and all but one of those clusters would stay empty.
pub fn weight_cap(total: u32, k: u32) -> u32 {
    total.div_ceil(k.max(1)).max(1)
}

/// How many times the cap is recomputed from the capped total: capping lowers the total, so
/// the cap too, toward the fixed point cap = ⌈Σ min(w, cap) / k⌉ (a texel with 90 % of the
/// importance and 16 seeds keeps 38 %, 9 %, 7 %, 7 % of the total after each pass). Where many
/// texels are near the cap it converges slowly: on the sun-lit living room (96 × 68, 1,000
/// clusters), 4 passes left 511 clusters with members, 8 left 587, 16 left 891, as 32 do.
pub const CAP_PASSES: u32 = 16;

/// One map's quantised importance, each texel capped at one seed's share ([`weight_cap`] for
/// `k` seeds, [`CAP_PASSES`] times), and its rows' running totals, from the importance of its
/// texels (`importance`, n², row-major).
pub fn map_weights(importance: &[f32], n: u32, k: u32) -> (Vec<u32>, Vec<u32>) {
    let max = importance.iter().copied().filter(|x| x.is_finite()).fold(0.0f32, f32::max);
    if max <= 0.0 {
        return (vec![0; importance.len()], vec![0; n as usize]);
    }
    let scale = quantum_scale(max, n * n);
    // (A negative importance, which no texel has, would quantise to 0 too: the cast saturates.)
    let q: Vec<u32> =
        importance.iter().map(|&x| if x.is_finite() { quantize(x, scale) } else { 0 }).collect();
    let mut cap = u32::MAX;
    for _ in 0..CAP_PASSES {
        cap = weight_cap(q.iter().map(|&w| w.min(cap)).sum(), k);
    }
    let q: Vec<u32> = q.into_iter().map(|w| w.min(cap)).collect();
    let mut rows = Vec::with_capacity(n as usize);
    let mut acc = 0u32;
    for row in q.chunks(n as usize) {
        acc += row.iter().sum::<u32>();
        rows.push(acc);
    }
    (q, rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// φ_b(i) by the textbook digit reversal, in f64.
    fn radical_inverse(mut i: u32, base: u32) -> f64 {
        let (mut x, mut f) = (0.0, 1.0 / base as f64);
        while i > 0 {
            x += (i % base) as f64 * f;
            i /= base;
            f /= base as f64;
        }
        x
    }

    #[test]
    fn halton_fractions_are_the_radical_inverses() {
        for i in [1u32, 2, 3, 7, 100, 255, 256, 4096, 531_440] {
            let (f2, f3) = halton_fractions(i);
            assert_eq!(
                f2 as f64,
                (radical_inverse(i, 2) * (1u64 << 20) as f64).floor(),
                "base 2 at {i}"
            );
            assert_eq!(
                f3 as f64,
                (radical_inverse(i, 3) * (1u64 << 20) as f64).floor(),
                "base 3 at {i}"
            );
        }
    }

    #[test]
    fn pixel_samples_cover_the_image_evenly() {
        let (w, h) = (64u32, 48u32);
        let samples = pixel_samples(w, h, 2);
        assert_eq!(samples.len(), PIXELS as usize);
        assert!(samples.iter().all(|&s| s % 2 == 0 && s < w * h * 2));
        // Every 16 x 12 block of the 4 x 4 grid over the image gets 256 / 16 = 16 pixels, give
        // or take the Halton points' discrepancy.
        let mut blocks = [0u32; 16];
        for s in samples {
            let (x, y) = ((s / 2) % w, (s / 2) / w);
            blocks[((y / 12) * 4 + x / 16) as usize] += 1;
        }
        assert!(blocks.iter().all(|&b| (14..=18).contains(&b)), "{blocks:?}");
    }

    fn vpl(position: Vec3, normal: Vec3, flux: f32) -> Vpl {
        Vpl {
            position: position.to_array(),
            path: 0,
            normal: normal.to_array(),
            bounce: 1,
            flux: [flux; 3],
            specular: 0,
            ..Default::default()
        }
    }

    /// The geometry term against its definition for two facing patches, and the floor.
    #[test]
    fn term_is_the_floored_geometry_term() {
        let v = vpl(Vec3::ZERO, Vec3::Y, 1.0);
        let p = Endpoint::new(Vec3::new(3.0, 4.0, 0.0), Vec3::NEG_Y);
        // cos_v = 4/5, cos_p = 4/5, d² = 25.
        assert!((term(&v, &p, 0.0) - 0.64 / 25.0).abs() < 1e-7);
        assert!((term(&v, &p, 100.0) - 0.64 / 100.0).abs() < 1e-7);
        // Behind either surface: nothing.
        assert_eq!(term(&v, &Endpoint::new(Vec3::new(0.0, -1.0, 0.0), Vec3::Y), 0.0), 0.0);
        assert_eq!(term(&v, &Endpoint::new(Vec3::new(0.0, 1.0, 0.0), Vec3::Y), 0.0), 0.0);
        let points = [p, p];
        assert!((importance(&v, &points, 0.0) - 3.0 * 2.0 * 0.64 / 25.0).abs() < 1e-6);
    }

    #[test]
    fn quantised_weights_stay_exact_and_within_31_bits() {
        for texels in [1u32, 2, 3, 64 * 64, 128 * 128, 4096 * 4096] {
            let bits = quantum_bits(texels);
            assert!((texels as u64) << bits <= 1u64 << 31, "{texels} texels of {bits} bits");
            for max in [1e-30f32, 3.7e-4, 1.0, 6.5e3, 2.0e20] {
                let s = quantum_scale(max, texels);
                assert_eq!(s.to_bits() & 0x7f_ffff, 0, "{s} is a power of two");
                let top = quantize(max, s);
                assert!(
                    top >= 1 << (bits - 1) && top <= 1 << bits,
                    "max {max} over {texels}: {top} of {bits} bits"
                );
            }
        }
    }

    /// Warped seeds land on texels in proportion to their weight: a map whose importance lies in
    /// two texels, one three times the other, gets its seeds 3 : 1 between them and none
    /// elsewhere; a map with no importance gives no warp.
    #[test]
    fn warped_seeds_follow_the_importance() {
        let n = 8u32;
        let mut importance = vec![0.0f32; 64];
        importance[2 * 8 + 5] = 3.0;
        importance[6 * 8 + 1] = 1.0;
        let (q, rows) = map_weights(&importance, n, 1);
        let mut hits = [0u32; 2];
        for i in 1..=400 {
            match warp(i, n, &q, &rows) {
                Some((5, 2)) => hits[0] += 1,
                Some((1, 6)) => hits[1] += 1,
                other => panic!("seed {i} at {other:?}"),
            }
        }
        assert!((297..=303).contains(&hits[0]), "{hits:?}");
        let (q0, rows0) = map_weights(&[0.0; 64], n, 1);
        assert_eq!(warp(1, n, &q0, &rows0), None);
    }

    /// A seed never lands on a texel without weight: where the target within a row is 0, the
    /// first texel of positive weight takes it, not the empty texels before it.
    #[test]
    fn seeds_skip_texels_without_weight() {
        let (q, rows) = (vec![0, 1, 1, 0], vec![1, 2]);
        for i in 1..=64 {
            let (x, y) = warp(i, 2, &q, &rows).expect("weights");
            assert_eq!(q[(y * 2 + x) as usize], 1, "seed {i} at ({x}, {y})");
        }
    }

    /// Texels whose importance is not finite get no weight (and do not set the scale): the
    /// others keep their seeds.
    #[test]
    fn non_finite_importance_gets_no_seed() {
        let importance = [f32::INFINITY, 1.0, f32::NAN, 3.0];
        let (q, rows) = map_weights(&importance, 2, 1);
        assert_eq!((q[0], q[2]), (0, 0));
        assert!(q[3] > 2 * q[1] && q[1] > 0, "{q:?}");
        assert_eq!(*rows.last().unwrap(), q[1] + q[3]);
    }

    /// A peak is capped at one seed's share: with 90 % of a map's importance on one texel, 16
    /// seeds land on at least 12 different texels (uncapped, about 14 of them would share the
    /// peak).
    #[test]
    fn a_peak_takes_one_seed() {
        let n = 16u32;
        let mut importance = vec![1.0f32; 256];
        importance[100] = 0.9 / 0.1 * 255.0;
        let distinct = |k: u32| {
            let (q, rows) = map_weights(&importance, n, k);
            (1..=16)
                .map(|i| warp(i, n, &q, &rows).expect("importance"))
                .collect::<std::collections::BTreeSet<_>>()
                .len()
        };
        assert!(distinct(16) >= 12, "{} texels", distinct(16));
        assert!(distinct(1) <= 4, "uncapped: {} texels", distinct(1));
        assert_eq!(weight_cap(100, 16), 7);
        assert_eq!(weight_cap(0, 16), 1);
    }

    /// Over a smooth importance, the warped seeds' histogram matches the importance: each of the
    /// 4 x 4 blocks of a 16² map holds its share of 4,096 seeds within 1 %.
    #[test]
    fn warped_seeds_match_a_smooth_importance() {
        let n = 16u32;
        let importance: Vec<f32> =
            (0..n * n).map(|t| (1 + t % n) as f32 * (1 + t / n) as f32).collect();
        let (q, rows) = map_weights(&importance, n, 1);
        let total: f64 = importance.iter().map(|&x| x as f64).sum();
        let mut blocks = [0u32; 16];
        let seeds = 4096u32;
        for i in 1..=seeds {
            let (x, y) = warp(i, n, &q, &rows).expect("importance everywhere");
            blocks[((y / 4) * 4 + x / 4) as usize] += 1;
        }
        for b in 0..16u32 {
            let share: f64 = (0..n * n)
                .filter(|t| ((t / n) / 4) * 4 + (t % n) / 4 == b)
                .map(|t| importance[t as usize] as f64)
                .sum::<f64>()
                / total;
            let got = blocks[b as usize] as f64 / seeds as f64;
            assert!(
                (got - share).abs() < 0.01,
                "block {b}: {got:.4} of the seeds for {share:.4} of the importance"
            );
        }
    }
}
