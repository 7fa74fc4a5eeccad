//! Exclusive prefix sums on the device (`shaders/scan.wgsl`), shared by the stages that compact.

use crate::buffers::{dispatch, kernel_params};
use crate::context::validated;
use crate::shader::pipeline;
use crate::GpuError;

/// Items one scan dispatch sums: each of its 256 threads walks its share twice, and lavapipe ends
/// an invocation's loops after 65,535 iterations (2 x 16,384 here).
pub const ITEMS_PER_DISPATCH: u32 = 1 << 22;

pub struct ScanKernel {
    pipeline: wgpu::ComputePipeline,
}

impl ScanKernel {
    pub fn new(device: &wgpu::Device) -> Result<Self, GpuError> {
        validated(device, "scan pipeline", || ScanKernel {
            pipeline: pipeline(device, "scan.wgsl", "main"),
        })
    }

    /// `offsets[i] = counts[0] + .. + counts[i - 1]` for i <= n (`offsets` holds n + 1 words; the
    /// last is the total), [`ITEMS_PER_DISPATCH`] items per dispatch.
    pub fn run(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        counts: &wgpu::Buffer,
        n: u32,
        offsets: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        validated(device, "scan", || {
            let mut first = 0;
            loop {
                let count = (n - first).min(ITEMS_PER_DISPATCH);
                let p = kernel_params(device, "scan params", &[n, first, count, 0]);
                dispatch(device, queue, &self.pipeline, &[&p, counts, offsets], 1);
                first += count;
                if first == n {
                    break;
                }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::buffers::{batched, read_back, storage, storage_zeroed};

    /// Past one dispatch's range (lavapipe's loop limiter) and across its seams, submitted
    /// dispatch by dispatch and recorded into one batch: every offset is the CPU's prefix sum.
    #[test]
    fn scans_past_one_dispatch_match_the_prefix_sum() {
        let Some(ctx) =
            crate::context::tests::test_gpu("scans_past_one_dispatch_match_the_prefix_sum")
        else {
            return;
        };
        let (device, queue) = (&ctx.device, &ctx.queue);
        let scan = ScanKernel::new(device).unwrap();
        for n in [0u32, 5, ITEMS_PER_DISPATCH, 2 * ITEMS_PER_DISPATCH + 3] {
            let counts: Vec<u32> = (0..n).map(|i| i.wrapping_mul(2_654_435_761) >> 30).collect();
            let mut want = Vec::with_capacity(n as usize + 1);
            let mut sum = 0u32;
            for &c in &counts {
                want.push(sum);
                sum += c;
            }
            want.push(sum);
            let buffer = storage(device, "counts", if n == 0 { &[0u32][..] } else { &counts });
            for in_batch in [false, true] {
                let offsets = storage_zeroed::<u32>(device, "offsets", n as usize + 1);
                let run = || scan.run(device, queue, &buffer, n, &offsets);
                if in_batch {
                    batched(device, queue, run).unwrap();
                } else {
                    run().unwrap();
                }
                let got = read_back::<u32>(device, queue, &offsets, n as usize + 1).unwrap();
                let first_wrong = got.iter().zip(&want).position(|(a, b)| a != b);
                assert_eq!(
                    first_wrong, None,
                    "n = {n} (batched: {in_batch}): offset {first_wrong:?} differs"
                );
            }
        }
    }
}
