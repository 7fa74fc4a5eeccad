//! Counter-based random numbers keyed by (seed, stream, index).
//!
//! Every random decision in vplgi is a pure function of the frame seed, a [`Stream`] naming what the
//! numbers are for, an item index (particle, pixel, ...) and a counter. No state is shared between
//! items, so results do not depend on thread count or scheduling, and a GPU thread can reproduce
//! the CPU's numbers exactly.
//!
//! The mixing function is the PCG-based integer hash recommended by Jarzynski and Olano
//! ("Hash Functions for GPU Rendering", JCGT 2020). It is a bijection on `u32`, so for a fixed key
//! the stream does not repeat within 2^32 draws. Only wrapping `u32` multiply, add, xor and shifts
//! are used: WGSL has the same operations with the same semantics.

/// What a stream of random numbers is used for. Different streams of the same (seed, index) are
/// independent.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    /// Light particles: light choice, emission point and direction, bounces, Russian roulette.
    LightPath = 1,
    /// Direct-light sampling at a shading point.
    Direct = 2,
    /// Sub-pixel jitter of camera samples.
    Camera = 3,
    /// Clustering: choice of the initial centroids.
    Cluster = 4,
    /// Reserved for independent estimators written by tests (the brute-force path tracer).
    Oracle = 5,
    /// The direction of a bias-compensation segment (`bias_points`).
    Bias = 6,
    /// Per-frame digital shifts of low-discrepancy sets shared by many items (index 0: the light
    /// particles' emission, `trace_vpls`).
    Scramble = 7,
    /// Adaptive seeding of the shading-point clustering: which hits of a quadtree node become
    /// seeds (`vplgi_shared::seeding`).
    Seeding = 8,
    /// The directions of the gather rays that measure a sample point's harmonic mean distance
    /// (`--shade interpolate`).
    Gather = 9,
    /// Reflect or refract at glass along a camera ray's specular chain (`shading_points`).
    Specular = 10,
    /// Reflect or refract at glass along a shadow-map texel's ray (`rsm_vpls`).
    RsmSpecular = 11,
}

/// The PCG hash: one LCG step followed by a random-rotation-like output permutation.
#[inline]
pub const fn pcg_hash(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A random stream: a key derived from (seed, stream, index) and a draw counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rng {
    key: u32,
    counter: u32,
}

impl Rng {
    #[inline]
    pub fn new(seed: u32, stream: Stream, index: u32) -> Self {
        let key =
            pcg_hash(index.wrapping_add(pcg_hash((stream as u32).wrapping_add(pcg_hash(seed)))));
        Rng { key, counter: 0 }
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let v = pcg_hash(self.key ^ pcg_hash(self.counter));
        self.counter = self.counter.wrapping_add(1);
        v
    }

    /// Uniform in [0, 1): the top 24 bits, so every value is exactly representable.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values_pin_the_generator() {
        // Pinned so that a change to the generator (which the WGSL twin must follow) is noticed.
        assert_eq!(pcg_hash(0), 129_708_002);
        let mut r = Rng::new(1, Stream::LightPath, 0);
        let first: Vec<u32> = (0..3).map(|_| r.next_u32()).collect();
        let mut again = Rng::new(1, Stream::LightPath, 0);
        assert_eq!(first, (0..3).map(|_| again.next_u32()).collect::<Vec<_>>());
    }

    #[test]
    fn streams_and_indices_differ() {
        let a = Rng::new(7, Stream::LightPath, 3).next_u32();
        let b = Rng::new(7, Stream::Direct, 3).next_u32();
        let c = Rng::new(7, Stream::LightPath, 4).next_u32();
        let d = Rng::new(8, Stream::LightPath, 3).next_u32();
        assert!(a != b && a != c && a != d);
    }

    #[test]
    fn floats_are_in_unit_interval_and_roughly_uniform() {
        let mut r = Rng::new(42, Stream::Oracle, 0);
        let n = 100_000;
        let mut bins = [0u32; 10];
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            bins[(x * 10.0) as usize] += 1;
        }
        // chi^2 with 9 degrees of freedom; 27.9 is the 0.999 quantile.
        let e = n as f64 / 10.0;
        let chi2: f64 = bins.iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 27.9, "chi2 = {chi2}");
    }
}
