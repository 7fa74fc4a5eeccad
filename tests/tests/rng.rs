//! `rng`: the WGSL twin of the counter-based RNG against the Rust one (SPEC: bit-identical).
//! Each test prints the adapter it ran on and the measured disagreement.

use proptest::prelude::*;
use vplgi_tests::tolerance::{Disagreement, RNG_DIFFERING_DRAWS};
use vplgi_types::{Rng, Stream};

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, failure_persistence: None, ..ProptestConfig::default() })]

    /// RNG: the WGSL twin gives bit-identical u32 streams (SPEC: bit-identical).
    #[test]
    fn rng_streams_are_bit_identical(seed in any::<u32>(), stream in 1u32..6, first in any::<u32>()) {
        let Some(ctx) = vplgi_tests::gpu("rng_streams_are_bit_identical") else { return Ok(()) };
        let (count, draws) = (512u32, 8u32);
        let first = first.min(u32::MAX - count);
        let gpu = vplgi_gpu::rng::rng_streams(&ctx.device, &ctx.queue, seed, stream, first, count, draws).unwrap();
        let stream_enum = [Stream::LightPath, Stream::Direct, Stream::Camera, Stream::Cluster, Stream::Oracle][(stream - 1) as usize];
        let mut mismatches = 0;
        for i in 0..count {
            let mut r = Rng::new(seed, stream_enum, first + i);
            for k in 0..draws {
                if r.next_u32() != gpu[(i * draws + k) as usize] {
                    mismatches += 1;
                }
            }
        }
        Disagreement::at_most("rng", "draws that differ", mismatches as f64, RNG_DIFFERING_DRAWS as f64).check();
    }
}
