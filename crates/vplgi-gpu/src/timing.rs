//! Device time of a piece of GPU work, from timestamp queries where the adapter has them: the
//! summed duration of its compute passes, without the host's encoding, submission and waiting
//! that a wall clock would include. The benches report this for the GPU variants, and
//! `vplgi render --profile` the time of every kernel (passes are named by the entry point that
//! `context::validated` runs them under).

use crate::GpuError;
use std::cell::RefCell;
use std::time::Duration;

thread_local! {
    /// The passes recorded on this thread: their kernel and a staging buffer holding a begin and
    /// an end timestamp; `None` when nothing is being timed.
    static PASSES: RefCell<Option<Vec<(String, wgpu::Buffer)>>> = const { RefCell::new(None) };
    /// The kernel the passes dispatched now belong to.
    static KERNEL: RefCell<String> = const { RefCell::new(String::new()) };
}

/// Runs `f` with the passes it dispatches attributed to `kernel` (restored afterwards).
pub(crate) fn in_kernel<T>(kernel: &str, f: impl FnOnce() -> T) -> T {
    let outer = KERNEL.with(|k| std::mem::replace(&mut *k.borrow_mut(), kernel.to_string()));
    let out = f();
    KERNEL.with(|k| *k.borrow_mut() = outer);
    out
}

/// Whether `device` can time passes (it was opened with `TIMESTAMP_QUERY`).
pub fn supported(device: &wgpu::Device) -> bool {
    device.features().contains(wgpu::Features::TIMESTAMP_QUERY)
}

/// Runs `work` and sums the device time of every compute pass it dispatches on this thread
/// (through `buffers::dispatch_windows`). The time is `None` on devices without timestamp
/// queries.
pub fn device_time<R>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    work: impl FnOnce() -> R,
) -> Result<(R, Option<Duration>), GpuError> {
    let (out, kernels) = device_time_by_kernel(device, queue, work)?;
    Ok((out, kernels.map(|k| k.iter().map(|k| k.time).sum())))
}

/// The device time of one kernel within some work.
#[derive(Clone, Debug, serde::Serialize)]
pub struct KernelTime {
    pub kernel: String,
    pub passes: u32,
    pub time: Duration,
}

/// Like [`device_time`], broken down by kernel, the most expensive first.
pub fn device_time_by_kernel<R>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    work: impl FnOnce() -> R,
) -> Result<(R, Option<Vec<KernelTime>>), GpuError> {
    if !supported(device) {
        return Ok((work(), None));
    }
    PASSES.with(|p| *p.borrow_mut() = Some(Vec::new()));
    let out = work();
    let (kernels, staging): (Vec<String>, Vec<wgpu::Buffer>) =
        PASSES.with(|p| p.borrow_mut().take()).unwrap_or_default().into_iter().unzip();
    let period_ns = queue.get_timestamp_period() as f64;
    let (tx, rx) = std::sync::mpsc::channel();
    for (i, b) in staging.iter().enumerate() {
        let tx = tx.clone();
        b.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send((i, r));
        });
    }
    drop(tx);
    crate::wait::wait_for_device(device, "timestamp read-back")?;
    let mut by_kernel: Vec<KernelTime> = Vec::new();
    for (i, r) in rx {
        r.map_err(|e| GpuError::Lost {
            what: "timestamp read-back".into(),
            message: e.to_string(),
        })?;
        let view = staging[i].get_mapped_range(..).map_err(|e| GpuError::Lost {
            what: "timestamp read-back".into(),
            message: e.to_string(),
        })?;
        let t: &[u64] = bytemuck::cast_slice(&view[..16]);
        let time = Duration::from_nanos((t[1].saturating_sub(t[0]) as f64 * period_ns) as u64);
        match by_kernel.iter_mut().find(|k| k.kernel == kernels[i]) {
            Some(k) => {
                k.passes += 1;
                k.time += time;
            }
            None => by_kernel.push(KernelTime { kernel: kernels[i].clone(), passes: 1, time }),
        }
    }
    by_kernel.sort_by(|a, b| b.time.cmp(&a.time).then_with(|| a.kernel.cmp(&b.kernel)));
    Ok((out, Some(by_kernel)))
}

/// Timestamp writes for the next pass when timing is on: the query set, and the buffers its two
/// timestamps are resolved into and read from.
pub(crate) struct PassQueries {
    pub set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    staging: wgpu::Buffer,
}

pub(crate) fn pass_queries(device: &wgpu::Device) -> Option<PassQueries> {
    let on = PASSES.with(|p| p.borrow().is_some());
    if !on {
        return None;
    }
    let set = device.create_query_set(&wgpu::QuerySetDescriptor {
        label: Some("pass time"),
        ty: wgpu::QueryType::Timestamp,
        count: 2,
    });
    let buffer = |label, usage| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: 16,
            usage,
            mapped_at_creation: false,
        })
    };
    let resolve = buffer(
        "pass time resolve",
        wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
    );
    let staging =
        buffer("pass time read-back", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
    Some(PassQueries { set, resolve, staging })
}

impl PassQueries {
    /// Records the resolve and copy after the pass, and keeps the buffer for `device_time`.
    pub(crate) fn finish(self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.set, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.staging, 0, 16);
        let kernel = KERNEL.with(|k| k.borrow().clone());
        PASSES.with(|p| {
            if let Some(v) = p.borrow_mut().as_mut() {
                v.push((if kernel.is_empty() { "unnamed".into() } else { kernel }, self.staging));
            }
        });
    }
}
