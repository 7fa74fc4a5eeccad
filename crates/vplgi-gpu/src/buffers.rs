//! Buffer upload and read-back.

use crate::wait::wait_for_device;
use crate::GpuError;
use bytemuck::Pod;
use std::cell::RefCell;

thread_local! {
    /// While [`batched`] runs on this thread: its device and queue, and the encoder its
    /// dispatches and copies are recorded into (opened on first use), submitted when the host
    /// needs results.
    static BATCH: RefCell<Option<Batch>> = const { RefCell::new(None) };
}

struct Batch {
    device: wgpu::Device,
    queue: wgpu::Queue,
    encoder: Option<wgpu::CommandEncoder>,
}

/// Runs `work` with every dispatch and copy it makes through this module recorded into one
/// command buffer, submitted when a read-back or [`sync`] needs the results and when `work`
/// ends, instead of one submission per dispatch: a submission has a fixed cost beyond the
/// dispatch it carries, and a clustering makes dozens of dispatches. `work` must send
/// nothing to `queue` by other means (`write_buffer`, its own submissions): those would run
/// before the recorded commands. Nested calls join the outer batch. Errors wgpu finds in the
/// recorded passes surface when they are submitted, as the error of that read-back or of this
/// call.
pub fn batched<T>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    work: impl FnOnce() -> Result<T, GpuError>,
) -> Result<T, GpuError> {
    if BATCH.with(|b| b.borrow().is_some()) {
        return work();
    }
    BATCH.with(|b| {
        *b.borrow_mut() =
            Some(Batch { device: device.clone(), queue: queue.clone(), encoder: None })
    });
    let out = work();
    let submitted = flush();
    BATCH.with(|b| *b.borrow_mut() = None);
    let out = out?;
    submitted.map(|_| out)
}

/// Submits what the batch on this thread has recorded so far, if anything, inside error scopes.
fn flush() -> Result<(), GpuError> {
    let pending = BATCH.with(|b| {
        b.borrow_mut().as_mut().and_then(|batch| {
            batch.encoder.take().map(|e| (batch.device.clone(), batch.queue.clone(), e))
        })
    });
    match pending {
        Some((device, queue, encoder)) => {
            crate::context::validated(&device, "batched dispatches", || {
                queue.submit([encoder.finish()])
            })
            .map(|_| ())
        }
        None => Ok(()),
    }
}

/// Records commands into the batch's encoder when a batch is open on this thread, else into a
/// new encoder submitted at once.
pub(crate) fn record(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    f: impl FnOnce(&mut wgpu::CommandEncoder),
) {
    let open = BATCH.with(|b| b.borrow_mut().as_mut().map(|batch| batch.encoder.take()));
    let in_batch = open.is_some();
    let mut encoder = open.flatten().unwrap_or_else(|| {
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
    });
    f(&mut encoder);
    if in_batch {
        BATCH.with(|b| {
            if let Some(batch) = b.borrow_mut().as_mut() {
                batch.encoder = Some(encoder);
            }
        });
    } else {
        queue.submit([encoder.finish()]);
    }
}

/// A storage buffer holding `data`. Empty data gets one zeroed element (at least 16 bytes):
/// bindings cannot be smaller than their element type. Shaders take counts from their
/// parameters, never from `arrayLength` of a possibly empty array.
pub fn storage<T: Pod>(device: &wgpu::Device, label: &str, data: &[T]) -> wgpu::Buffer {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    let zeros = vec![0u8; std::mem::size_of::<T>().max(16)];
    let contents = if bytes.is_empty() { &zeros[..] } else { bytes };
    filled(
        device,
        label,
        contents,
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    )
}

/// A buffer created mapped and filled with `contents` (padded to 4 bytes). Unlike wgpu's
/// `create_buffer_init`, which panics when the mapping fails, a device that is lost (or out of
/// memory) leaves the buffer unfilled: the buffer is invalid, wgpu reports that to the error
/// scope around the call or to the context's error sink, and the next read-back fails with
/// [`GpuError::Lost`].
fn filled(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let size = (contents.len() as u64)
        .next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT)
        .max(wgpu::COPY_BUFFER_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage,
        mapped_at_creation: true,
    });
    if let Ok(mut view) = buffer.get_mapped_range_mut(..) {
        view.slice(..contents.len()).copy_from_slice(contents);
        drop(view);
        buffer.unmap();
    }
    buffer
}

/// A zeroed storage buffer of `len` elements of `T` (at least one element and 16 bytes, like
/// [`storage`]).
pub fn storage_zeroed<T: Pod>(device: &wgpu::Device, label: &str, len: usize) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: ((len.max(1) * std::mem::size_of::<T>()) as u64).max(16).next_multiple_of(4),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A kernel's parameters: a read-only storage buffer holding `value`, not a uniform buffer.
/// Lavapipe inlines the values of uniform buffers into the shader and JIT-compiles a new variant
/// for every new set of values, so parameters that change from dispatch to dispatch (windows,
/// chunks, counts) cost an LLVM compile each (measured: 0.7 s of every 0.73 s a random
/// assignment case took). Storage buffers are read as data. Every `Params` struct holds only
/// 4-byte scalars and vec4s, whose layout is the same in both address spaces.
pub fn kernel_params<T: Pod>(device: &wgpu::Device, label: &str, value: &T) -> wgpu::Buffer {
    filled(device, label, bytemuck::bytes_of(value), wgpu::BufferUsages::STORAGE)
}

/// Copies the first `len` elements of `buffer` back to the host. Waits with a timeout, so a lost
/// or hung device becomes an error instead of a hang.
pub fn read_back<T: Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
    len: usize,
) -> Result<Vec<T>, GpuError> {
    let size = (len * std::mem::size_of::<T>()) as u64;
    if size == 0 {
        return Ok(Vec::new());
    }
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size: size.next_multiple_of(4),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    record(device, queue, |e| {
        e.copy_buffer_to_buffer(buffer, 0, &staging, 0, size.next_multiple_of(4))
    });
    flush()?;
    let (tx, rx) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    wait_for_device(device, "read-back")?;
    match rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            return Err(GpuError::Lost { what: "read-back".into(), message: e.to_string() })
        }
        Err(e) => return Err(GpuError::Lost { what: "read-back".into(), message: e.to_string() }),
    }
    let view = staging
        .get_mapped_range(..)
        .map_err(|e| GpuError::Lost { what: "read-back".into(), message: e.to_string() })?;
    let out = bytemuck::cast_slice::<u8, T>(&view[..size as usize]).to_vec();
    drop(view);
    staging.unmap();
    Ok(out)
}

/// Records one compute dispatch of `pipeline` with `buffers` bound in order at group 0 and
/// submits it. `groups` is split over y when it exceeds the per-dimension limit; shaders
/// linearise with `thread_index` (shaders/common/types.wgsl).
pub fn dispatch(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[&wgpu::Buffer],
    groups: u32,
) {
    let bound: Vec<(u32, &wgpu::Buffer)> =
        buffers.iter().enumerate().map(|(i, b)| (i as u32, *b)).collect();
    dispatch_bound(device, queue, pipeline, &bound, groups);
}

/// Like [`dispatch`], with explicit binding numbers: a pipeline whose layout is derived from one
/// entry point of a multi-entry module only has the bindings that entry point uses.
pub fn dispatch_bound(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[(u32, &wgpu::Buffer)],
    groups: u32,
) {
    let whole: Vec<(u32, wgpu::BufferBinding)> =
        buffers.iter().map(|(i, b)| (*i, b.as_entire_buffer_binding())).collect();
    dispatch_windows(device, queue, pipeline, &whole, groups);
}

/// Like [`dispatch_bound`], with any buffer bindings, e.g. [`Window`]s of per-item arrays
/// larger than one binding.
pub fn dispatch_windows(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[(u32, wgpu::BufferBinding)],
    groups: u32,
) {
    let layout = pipeline.get_bind_group_layout(0);
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: *i,
            resource: wgpu::BindingResource::Buffer(b.clone()),
        })
        .collect();
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &entries,
    });
    let timed = crate::timing::pass_queries(device);
    record(device, queue, |encoder| {
        let timestamp_writes = timed.as_ref().map(|t| wgpu::ComputePassTimestampWrites {
            query_set: &t.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        });
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind, &[]);
        let max = device.limits().max_compute_workgroups_per_dimension.max(1);
        let (x, y) = if groups <= max { (groups.max(1), 1) } else { (max, groups.div_ceil(max)) };
        pass.dispatch_workgroups(x, y, 1);
        drop(pass);
        if let Some(t) = timed {
            t.finish(encoder);
        }
    });
}

/// One u32 of `buffer`, at element `index` (for the few counters the host needs).
pub fn read_word(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
    index: u64,
) -> Result<u32, GpuError> {
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("word"),
        size: 4,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    record(device, queue, |e| e.copy_buffer_to_buffer(buffer, index * 4, &staging, 0, 4));
    Ok(read_back::<u32>(device, queue, &staging, 1)?[0])
}

/// Waits until the device has finished all submitted work (stage timing boundaries).
pub fn sync(device: &wgpu::Device) -> Result<(), GpuError> {
    flush()?;
    wait_for_device(device, "waiting for the device")
}

/// Windows start on multiples of this many elements: 64 elements of at least 4 bytes are 256
/// bytes, the largest storage offset alignment wgpu allows.
pub const WINDOW_ALIGN: u64 = 64;

/// A run of items `first .. first + count` of per-item arrays that may be larger than one
/// storage binding (points, their labels and weights). Windows start on a multiple of
/// [`WINDOW_ALIGN`] items, so every array of the run can be bound at its own byte offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub first: u64,
    pub count: u64,
}

impl Window {
    /// The whole run of `n` items in windows of at most `limit` bytes for the widest array
    /// (`item_bytes` per item); at least [`WINDOW_ALIGN`] items each. Empty for `n = 0`.
    pub fn split(n: u64, item_bytes: u64, limit: u64) -> Vec<Window> {
        let per = ((limit / item_bytes.max(1)) / WINDOW_ALIGN).max(1) * WINDOW_ALIGN;
        (0..n.div_ceil(per))
            .map(|i| Window { first: i * per, count: per.min(n - i * per) })
            .collect()
    }

    /// The smallest window holding items `first .. end`: it starts at the aligned item at or
    /// below `first`, which shaders subtract as the window's `first`.
    pub fn covering(first: u64, end: u64) -> Window {
        let start = first - first % WINDOW_ALIGN;
        Window { first: start, count: end.max(first) - start }
    }

    /// This window of `buffer`, whose items are `per_item` elements of `T`. An empty window
    /// binds the buffer's first item (buffers here hold at least one), which nothing reads.
    pub fn of<'a, T>(&self, buffer: &'a wgpu::Buffer, per_item: u64) -> wgpu::BufferBinding<'a> {
        let item = (per_item * std::mem::size_of::<T>() as u64).max(4);
        if self.count == 0 {
            return wgpu::BufferBinding {
                buffer,
                offset: 0,
                size: std::num::NonZeroU64::new(item),
            };
        }
        wgpu::BufferBinding {
            buffer,
            offset: self.first * item,
            size: std::num::NonZeroU64::new(self.count * item),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_cover_the_run_once_and_start_aligned() {
        for (n, item, limit) in [
            (0u64, 32u64, 1024u64),
            (1, 32, 1024),
            (1000, 32, 4096),
            (1000, 64, 100),
            (5000, 4, 1 << 20),
        ] {
            let w = Window::split(n, item, limit);
            let mut next = 0;
            for x in &w {
                assert_eq!(x.first, next, "gap or overlap at {x:?}");
                assert_eq!(x.first % WINDOW_ALIGN, 0);
                assert!(x.count > 0);
                // Within the limit unless the limit is below one aligned group of items.
                assert!(
                    x.count * item <= limit.max(WINDOW_ALIGN * item),
                    "{x:?} exceeds {limit} B"
                );
                next += x.count;
            }
            assert_eq!(next, n);
        }
        let c = Window::covering(130, 200);
        assert_eq!((c.first, c.count), (128, 72));
        assert_eq!(Window::covering(64, 64).count, 0);
    }

    /// Inside `batched`, dispatches run in the order they were recorded and a read-back sees all
    /// of them (it submits what is pending), nested batches join the outer one, the rest is
    /// submitted when the batch ends, and an invalid pass recorded into the batch still comes
    /// back as an error.
    #[test]
    fn batched_dispatches_run_in_order_and_report_errors() {
        let Some(ctx) =
            crate::context::tests::test_gpu("batched_dispatches_run_in_order_and_report_errors")
        else {
            return;
        };
        let (device, queue) = (&ctx.device, &ctx.queue);
        // Each dispatch doubles every word and adds 1, so the result tells how many ran, in order.
        let src = "@group(0) @binding(0) var<storage, read_write> a: array<u32>;\n\
                   @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) g: vec3<u32>) {\n\
                   if (g.x < arrayLength(&a)) { a[g.x] = a[g.x] * 2u + 1u; } }";
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: None,
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: None,
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let words = storage_zeroed::<u32>(device, "words", 100);
        let step = || dispatch(device, queue, &pipeline, &[&words], 2);
        let seen = batched(device, queue, || {
            step();
            step();
            let after_two = read_back::<u32>(device, queue, &words, 100)?;
            batched(device, queue, || {
                step();
                Ok(())
            })?;
            step();
            Ok(after_two)
        })
        .unwrap();
        assert!(seen.iter().all(|&w| w == 3), "a read-back inside the batch saw {:?}", &seen[..4]);
        let end = read_back::<u32>(device, queue, &words, 100).unwrap();
        assert!(end.iter().all(|&w| w == 15), "after the batch: {:?}", &end[..4]);

        // A 4-byte buffer where the shader needs 48-byte records.
        let kernel = crate::visibility::VisibilityKernel::new(device).unwrap();
        let scene =
            crate::scene::GpuScene::new(device, &vplgi_scene::cornell::cornell_box()).unwrap();
        let tiny = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("too small"),
            size: 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let r = batched(device, queue, || {
            kernel.run_on_device(device, queue, &scene, (&tiny, 1), (&tiny, 1), 0..1).map(|_| ())
        });
        assert!(
            matches!(r, Err(GpuError::Validation { .. })),
            "the invalid pass was not reported: {:?}",
            r.err()
        );
    }
}
