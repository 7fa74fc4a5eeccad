//! Adaptive seeding of the shading-point clustering (Wang et al. 2009, section 3.2): the rules
//! every backend follows, so that given the same hits both choose the same seeds.
//!
//! * **Quadtree.** A static quadtree over the image, padded to a square of side `2^L`. Level
//!   `l` (1 ..= L) has `(2^L >> l)²` nodes of `2^l x 2^l` pixels; the root is level L. Level 1
//!   (2 x 2 pixels) is the finest: a node that small chooses among its hits directly.
//! * **Geometric variation** ε_q of a node: the sum over its hits of Eq. 2 (α |x - x̄| +
//!   sqrt(2 - 2 n . n̄)) against the node's mean position x̄ and mean normal n̄, the mean taken
//!   with the clustering's fixed-point sums (`vplgi_types::clustering::FixedPoint`). Each hit's
//!   error is rounded to a multiple of 2^-16 ([`quantize_error`]) and summed as an integer, so
//!   the sum does not depend on the order of addition. The sum, not the mean: a node's share of
//!   seeds grows with its area as well as with its variation.
//! * **Distribution.** The root gets K seeds (at most one per hit). A node with `s` seeds:
//!   - `s >= n` (its hit count; only where K is at least the frame's hits): every hit is a seed
//!     (each child gets as many seeds as it has hits, down to level 1);
//!   - `s == 1`, or a level-1 node: `s` hits by jittered sampling of their ranks ([`ranks`]);
//!   - otherwise its four children share the `s` in proportion to their ε, or to their hit
//!     counts if every child's ε is 0, none getting more seeds than it has hits
//!     ([`capped_shares`]); so a frame gets exactly min(K, hits) seeds.
//! * **Order.** Seeds are numbered in the quadtree's depth-first order (children (0, 0), (1, 0),
//!   (0, 1), (1, 1)); a node's hits are ranked in the same order, then by hit index within a
//!   pixel. Each node owns `s` slots from its parent's offset; unused slots are dropped.

/// The seeding's parameters, here too so one `use` reaches them with the quadtree.
pub use vplgi_types::params::SeedParams;
use vplgi_types::{Rng, Stream};

/// The quadtree over an image of `width x height` pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadtree {
    pub width: u32,
    pub height: u32,
    /// L: the padded side is 2^L, the root is level L (at least 1).
    pub levels: u32,
}

impl Quadtree {
    pub fn new(width: u32, height: u32) -> Quadtree {
        let side = width.max(height).max(2).next_power_of_two();
        Quadtree { width, height, levels: side.trailing_zeros() }
    }

    /// Nodes per side at level `l`.
    pub fn side(&self, l: u32) -> u32 {
        1 << (self.levels - l)
    }

    /// Where level `l`'s nodes start in one array of every level, finest (1) first.
    pub fn level_offset(&self, l: u32) -> u32 {
        (1..l).map(|m| self.side(m) * self.side(m)).sum()
    }

    /// Nodes of every level.
    pub fn nodes(&self) -> u32 {
        self.level_offset(self.levels + 1)
    }

    /// The node of level `l` at (`x`, `y`) in that level's nodes, in the array of every level.
    pub fn node(&self, l: u32, x: u32, y: u32) -> u32 {
        self.level_offset(l) + y * self.side(l) + x
    }

    /// Pixel index of pixel (`x`, `y`), or `None` outside the image (the padding).
    pub fn pixel(&self, x: u32, y: u32) -> Option<u32> {
        (x < self.width && y < self.height).then(|| y * self.width + x)
    }
}

/// The child (0 ..= 3) order: (0, 0), (1, 0), (0, 1), (1, 1).
pub const CHILDREN: [(u32, u32); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];

/// The most samples per pixel the GPU's adaptive seeding takes for a quadtree of `levels`: a
/// pixel's invocation walks its hits once per level, and a first-level node's the hits of its
/// four pixels, all in one invocation, which lavapipe ends after 65,535 loop iterations (48,000
/// budgeted, as `vplgi_gpu::shade::LOOP_BUDGET`). Larger spp is refused up front.
pub fn max_spp(levels: u32) -> u32 {
    48_000 / (levels + 8)
}

/// Scale of a quantized Eq. 2 error: 2^16 per unit.
pub const ERROR_ONE: f32 = 65_536.0;

/// A hit's Eq. 2 error as an integer of [`ERROR_ONE`] steps (rounded to even, saturating).
#[inline]
pub fn quantize_error(e: f32) -> u32 {
    (e * ERROR_ONE).round_ties_even().min(u32::MAX as f32) as u32
}

/// A u64 as f32 through its two 32-bit halves (the GPU's arithmetic).
#[inline]
pub fn u64_f32(x: u64) -> f32 {
    (x >> 32) as u32 as f32 * 4_294_967_296.0 + x as u32 as f32
}

/// How `s` seeds are split among four children of weights `w`: child j gets
/// `floor(s c_j / W) - floor(s c_(j-1) / W)`, with c_j the cumulative weight and W the total,
/// in f32. The shares sum to `s` exactly (c_3 / W is 1) and are never negative (each step is
/// monotonic). All-zero weights give nothing.
pub fn shares(s: u32, w: [u64; 4]) -> [u32; 4] {
    let total: u64 = w.iter().sum();
    let mut out = [0u32; 4];
    if total == 0 {
        return out;
    }
    let t = u64_f32(total);
    let (mut cum, mut before) = (0u64, 0u32);
    for j in 0..4 {
        cum += w[j];
        let upto = (s as f32 * (u64_f32(cum) / t)).floor() as u32;
        out[j] = upto - before;
        before = upto;
    }
    out
}

/// [`shares`] with each child holding at most `cap` (its hits) seeds, for `s` below the
/// caps' sum: children whose share reaches their cap keep exactly the cap, and what remains is
/// shared again among the others by their weights (or, if those are all 0, their caps), until
/// no share reaches its cap. At most four rounds; the result sums to `s`.
pub fn capped_shares(s: u32, w: [u64; 4], cap: [u32; 4]) -> [u32; 4] {
    let mut out = [0u32; 4];
    // A child without hits takes nothing, whatever its weight.
    let mut full = cap.map(|c| c == 0);
    loop {
        let left = s - (0..4).filter(|&j| full[j]).map(|j| out[j]).sum::<u32>();
        let mut open = [0u64; 4];
        for j in 0..4 {
            open[j] = if full[j] { 0 } else { w[j] };
        }
        if open.iter().all(|&x| x == 0) {
            for j in 0..4 {
                open[j] = if full[j] { 0 } else { cap[j] as u64 };
            }
        }
        let sh = shares(left, open);
        let mut saturated = false;
        for j in 0..4 {
            if !full[j] && sh[j] >= cap[j] {
                (out[j], full[j], saturated) = (cap[j], true, true);
            }
        }
        if !saturated {
            for j in 0..4 {
                if !full[j] {
                    out[j] = sh[j];
                }
            }
            return out;
        }
    }
}

/// The ranks (0 .. n, increasing) of the `s` < `n` hits a node picks by jittered sampling: one
/// in each of `s` strata of its `n` ranked hits, stratum j being ranks `floor(j r) ..
/// floor((j + 1) r)` with r = n / s > 1 (the last ending at n), at offset `floor(u_j len)` with
/// u_j the node's j-th draw. All in f32, the GPU's arithmetic; strata are at least one rank
/// long, so the picks are distinct.
pub fn ranks(seed: u32, node: u32, s: u32, n: u32) -> impl Iterator<Item = u32> {
    let mut rng = Rng::new(seed, Stream::Seeding, node);
    let r = n as f32 / s as f32;
    (0..s).map(move |j| {
        let lo = (j as f32 * r).floor() as u32;
        let hi = if j + 1 == s { n } else { ((j + 1) as f32 * r).floor() as u32 };
        let len = hi.saturating_sub(lo).max(1);
        lo + ((rng.next_f32() * len as f32) as u32).min(len - 1)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadtree_levels_cover_the_padded_image() {
        let q = Quadtree::new(5, 3);
        assert_eq!(q.levels, 3, "5 x 3 pads to 8 x 8");
        assert_eq!((q.side(1), q.side(2), q.side(3)), (4, 2, 1));
        assert_eq!(
            (q.level_offset(1), q.level_offset(2), q.level_offset(3), q.nodes()),
            (0, 16, 20, 21)
        );
        assert_eq!(q.node(3, 0, 0), 20);
        assert_eq!(q.pixel(4, 2), Some(14));
        assert_eq!(q.pixel(5, 0), None);
        assert_eq!(Quadtree::new(1, 1).levels, 1, "even one pixel has a root of 2 x 2");
    }

    /// Against Rust's correctly rounded `as f32`: within the two roundings of the halves and the
    /// one of their sum, below 2^32 and above it where the low half is large against the high one
    /// (the shares' weights are sums of quantized errors and pass 2^32 on large images).
    #[test]
    fn u64s_convert_within_their_roundings() {
        let mut rng = vplgi_types::Rng::new(3, vplgi_types::Stream::Seeding, 0);
        let edges = [
            0u64,
            1,
            u32::MAX as u64,
            1 << 32,
            (1 << 32) + u32::MAX as u64,
            (3 << 40) | 0x8000_0000,
            u64::MAX,
        ];
        let random = (0..1000)
            .map(|_| ((rng.next_u32() as u64) << (rng.next_u32() % 33)) | rng.next_u32() as u64);
        for x in edges.into_iter().chain(random) {
            let (got, exact) = (u64_f32(x) as f64, x as f64);
            assert!(
                (got - exact).abs() <= exact * 2.0 * f32::EPSILON as f64,
                "{x}: {got} vs {exact}"
            );
        }
    }

    #[test]
    fn shares_follow_the_weights_and_sum_to_the_seeds() {
        assert_eq!(shares(10, [1, 1, 1, 1]), [2, 3, 2, 3]);
        assert_eq!(shares(8, [0, 3, 0, 1]), [0, 6, 0, 2]);
        assert_eq!(shares(5, [0, 0, 0, 0]), [0; 4]);
        assert_eq!(shares(3, [u64::MAX / 8, 0, 0, u64::MAX / 8]), [1, 0, 0, 2]);
        for s in 0..200u32 {
            for w in [[7u64, 0, 2, 100], [1 << 40, 1, 1 << 40, 3], [0, 0, 0, 9]] {
                let sh = shares(s, w);
                assert_eq!(sh.iter().sum::<u32>(), s, "{s} seeds over {w:?}: {sh:?}");
                for j in 0..4 {
                    if w[j] == 0 {
                        assert_eq!(sh[j], 0, "a child of no weight gets no seed");
                    }
                }
            }
        }
    }

    #[test]
    fn capped_shares_never_exceed_a_child_s_hits() {
        // The heavy child would get 9 of 10; it holds 3, the rest goes by weight to the others.
        assert_eq!(capped_shares(10, [90, 5, 5, 0], [3, 10, 10, 4]), [3, 3, 4, 0]);
        // The weights left are all 0: by hits.
        assert_eq!(capped_shares(6, [50, 0, 0, 0], [2, 1, 3, 0]), [2, 1, 3, 0]);
        for s in 0..40u32 {
            for (w, cap) in [
                ([7u64, 0, 2, 100], [5u32, 9, 9, 20]),
                ([1, 1, 1, 1], [0, 40, 1, 2]),
                ([0, 0, 0, 9], [10, 10, 10, 10]),
            ] {
                if s >= cap.iter().sum::<u32>() {
                    continue;
                }
                let sh = capped_shares(s, w, cap);
                assert_eq!(sh.iter().sum::<u32>(), s, "{s} over {w:?} capped {cap:?}: {sh:?}");
                assert!((0..4).all(|j| sh[j] <= cap[j]), "{s} over {w:?} capped {cap:?}: {sh:?}");
            }
        }
    }

    #[test]
    fn ranks_take_one_hit_per_stratum() {
        for (s, n) in [(1u32, 1u32), (1, 9), (3, 4), (5, 17), (40, 41)] {
            let r: Vec<u32> = ranks(7, 3, s, n).collect();
            assert_eq!(r.len(), s as usize);
            for (j, &x) in r.iter().enumerate() {
                let (lo, hi) =
                    (j as f32 * n as f32 / s as f32, (j + 1) as f32 * n as f32 / s as f32);
                assert!(
                    x as f32 >= lo.floor() && (x as f32) < hi.ceil() && x < n,
                    "{s} of {n}: rank {x} outside stratum {j}"
                );
            }
            assert!(r.windows(2).all(|p| p[0] < p[1]), "{s} of {n}: {r:?}");
        }
        // 11 (13 / 11) rounds to 12.99... in f32: the last stratum must still end at rank 12, not
        // at floor(s r), or the node's last hit could never be picked.
        assert!(
            (0..64).any(|node| ranks(7, node, 11, 13).last() == Some(12)),
            "rank 12 of 13 is never picked"
        );
    }

    #[test]
    fn errors_quantize_to_2_to_the_minus_16() {
        assert_eq!(quantize_error(0.0), 0);
        assert_eq!(quantize_error(1.0), 65_536);
        assert_eq!(quantize_error(1.5 / 65_536.0), 2, "ties to even");
        assert_eq!(quantize_error(1e30), u32::MAX);
    }
}
