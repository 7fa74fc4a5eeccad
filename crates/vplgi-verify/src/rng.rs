//! `rng`: the WGSL twin of the counter-based RNG against the Rust one (SPEC: bit-identical).

use crate::tolerance::{Disagreement, RNG_DIFFERING_DRAWS};
use crate::{result, Plan, StageResult, Twins, VerifyError, VerifyStage};
use vplgi_types::{Rng, Stream};

/// Every stream the pipeline draws from.
pub const STREAMS: [Stream; 8] = [
    Stream::LightPath,
    Stream::Direct,
    Stream::Camera,
    Stream::Cluster,
    Stream::Oracle,
    Stream::Bias,
    Stream::Scramble,
    Stream::Seeding,
];

/// Draws `draws` numbers from each of the counters `first .. first + count` of `stream` on both
/// sides and counts the draws that differ; the worst item is the first of them.
pub fn compare(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    seed: u32,
    stream: Stream,
    first: u32,
    count: u32,
    draws: u32,
) -> Result<Disagreement, VerifyError> {
    let first = first.min(u32::MAX - count);
    let gpu = vplgi_gpu::rng::rng_streams(device, queue, seed, stream as u32, first, count, draws)?;
    let (mut differ, mut worst) = (0u64, None);
    for i in 0..count {
        let mut r = Rng::new(seed, stream, first + i);
        for k in 0..draws {
            let (c, g) = (r.next_u32(), gpu[(i * draws + k) as usize]);
            if c != g {
                differ += 1;
                worst.get_or_insert_with(|| {
                    format!("counter {} draw {k}: CPU {c:#010x}, GPU {g:#010x}", first + i)
                });
            }
        }
    }
    let case = format!(
        "seed {seed}, stream {stream:?}, counters {first}..{}",
        first as u64 + count as u64
    );
    Ok(Disagreement::at_most("rng", "draws that differ", differ as f64, RNG_DIFFERING_DRAWS as f64)
        .with_case(case)
        .with_worst(worst))
}

/// Every stream at the frame's seed, at the first counters and at the last ones (where a
/// counter's arithmetic would wrap).
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::Rng);
    let (count, draws) = (4096, 8);
    for stream in STREAMS {
        for first in [0, u32::MAX - count] {
            r.checks.push(compare(
                twins.device(),
                twins.queue(),
                cfg.seed,
                stream,
                first,
                count,
                draws,
            )?);
        }
    }
    r.notes.push(format!(
        "{count} counters x {draws} draws per stream and range, compared bit for bit"
    ));
    Ok(r)
}
