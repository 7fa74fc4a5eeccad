//! `rng`: the WGSL twin of the counter-based RNG against the Rust one (SPEC: bit-identical).
//! Each test prints the adapter it ran on and the measured disagreement.

use proptest::prelude::*;
use vplgi_types::Stream;

proptest! {
    #![proptest_config(vplgi_tests::proptest_config(16))]

    /// RNG: the WGSL twin gives bit-identical u32 streams for any seed, stream and counter range
    /// (SPEC: bit-identical), measured by `vplgi verify`'s comparison.
    #[test]
    fn rng_streams_are_bit_identical(seed in any::<u32>(), stream in 0usize..5, first in any::<u32>(), draws in 1u32..16) {
        let Some(gpu) = vplgi_tests::shared_gpu("rng_streams_are_bit_identical") else { return Ok(()) };
        let stream: Stream = vplgi_verify::rng::STREAMS[stream];
        let d = vplgi_verify::rng::compare(&gpu.ctx.device, &gpu.ctx.queue, seed, stream, first, 512, draws).expect("GPU");
        vplgi_tests::hold(&[d])?;
    }
}
