//! Device time of a piece of GPU work, from timestamp queries where the adapter has them: the
//! summed duration of its compute passes, without the host's encoding, submission and waiting
//! that a wall clock would include. The benches report this for the GPU variants.

use crate::GpuError;
use std::cell::RefCell;
use std::time::Duration;

thread_local! {
    /// Staging buffers of the passes recorded on this thread, each holding a begin and an end
    /// timestamp; `None` when nothing is being timed.
    static PASSES: RefCell<Option<Vec<wgpu::Buffer>>> = const { RefCell::new(None) };
}

/// Whether `device` can time passes (it was opened with `TIMESTAMP_QUERY`).
pub fn supported(device: &wgpu::Device) -> bool {
    device.features().contains(wgpu::Features::TIMESTAMP_QUERY)
}

/// Runs `work` and sums the device time of every compute pass it dispatches on this thread
/// (through `buffers::dispatch_windows`). The time is `None` on devices without timestamp
/// queries.
pub fn device_time<R>(device: &wgpu::Device, queue: &wgpu::Queue, work: impl FnOnce() -> R) -> Result<(R, Option<Duration>), GpuError> {
    if !supported(device) {
        return Ok((work(), None));
    }
    PASSES.with(|p| *p.borrow_mut() = Some(Vec::new()));
    let out = work();
    let staging = PASSES.with(|p| p.borrow_mut().take()).unwrap_or_default();
    let period_ns = queue.get_timestamp_period() as f64;
    let (tx, rx) = std::sync::mpsc::channel();
    for (i, b) in staging.iter().enumerate() {
        let tx = tx.clone();
        b.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send((i, r));
        });
    }
    drop(tx);
    crate::buffers::sync(device)?;
    let mut ticks = 0u64;
    for (i, r) in rx {
        r.map_err(|e| GpuError::Lost { what: "timestamp read-back".into(), message: e.to_string() })?;
        let view = staging[i].get_mapped_range(..).map_err(|e| GpuError::Lost { what: "timestamp read-back".into(), message: e.to_string() })?;
        let t: &[u64] = bytemuck::cast_slice(&view[..16]);
        ticks += t[1].saturating_sub(t[0]);
    }
    Ok((out, Some(Duration::from_nanos((ticks as f64 * period_ns) as u64))))
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
    let set = device.create_query_set(&wgpu::QuerySetDescriptor { label: Some("pass time"), ty: wgpu::QueryType::Timestamp, count: 2 });
    let buffer = |label, usage| device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: 16, usage, mapped_at_creation: false });
    let resolve = buffer("pass time resolve", wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC);
    let staging = buffer("pass time read-back", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
    Some(PassQueries { set, resolve, staging })
}

impl PassQueries {
    /// Records the resolve and copy after the pass, and keeps the buffer for `device_time`.
    pub(crate) fn finish(self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.set, 0..2, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.staging, 0, 16);
        PASSES.with(|p| {
            if let Some(v) = p.borrow_mut().as_mut() {
                v.push(self.staging);
            }
        });
    }
}
