//! How fast each way of reading memory is on the GPU adapter: the measurement behind where the
//! kernels keep the data they read per lane (on lavapipe, a storage-buffer load is a loop over the
//! 8 lanes with a bounds check per lane and component; a texel fetch is not).
//!
//! Each of 65,536 invocations reads 256 `vec4<u32>` and folds them into one word, from a table of
//! 64 KiB (64 x 64 texels, in cache) and of 16 MiB (1,024 x 1,024), in four ways: a storage buffer at an index that differs per lane
//! (a BVH node during traversal), a storage buffer at the same index in every lane (a light in
//! `shade`), per lane by half of the lanes at random (divergent code: traversal, where lanes
//! finish at their own time), and the same three reads from an `rgba32uint` texture with
//! `textureLoad`. Every variant
//! must fold to the same words as its twin, or the run fails. Medians of 5 runs.
//!
//! Run: `cargo run --release -p vplgi-gpu --example load_paths`

use std::time::Instant;
use wgpu::util::DeviceExt;

/// Table sides: 64 (64 KiB, cache-resident like a small scene's BVH) and 1,024 (16 MiB).
const SIDES: [u32; 2] = [64, 1024];
const INVOCATIONS: u32 = 65_536;
const READS: u32 = 256;

const SHADER: &str = r#"
@group(0) @binding(0) var<storage, read> table: array<vec4<u32>>;
@group(0) @binding(1) var texels: texture_2d<u32>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;

override SIDE: u32;
const READS: u32 = 256u;

// The index of read r of invocation i: per lane (a hash of both) or the same in every lane.
fn index(i: u32, r: u32, per_lane: bool) -> u32 {
    var h = select(r, i * 2654435761u + r * 40503u, per_lane);
    h = (h ^ (h >> 15u)) * 2246822519u;
    return (h ^ (h >> 13u)) % (SIDE * SIDE);
}

fn fold(v: vec4<u32>) -> u32 {
    return v.x ^ (v.y * 3u) ^ (v.z * 5u) ^ (v.w * 7u);
}

// With `divergent`, a lane reads only where a hash of (lane, read) says so (about half the
// time, at random): the active lanes of a SIMD group differ from read to read, as in BVH
// traversal, where lanes visit nodes in their own order and finish at their own time.
fn lane_reads(i: u32, r: u32, divergent: bool) -> bool {
    return !divergent || (((i * 747796405u + r * 2891336453u) >> 13u) & 1u) == 1u;
}

fn buffer_reads(i: u32, per_lane: bool, divergent: bool) -> u32 {
    var acc = 0u;
    for (var r = 0u; r < READS; r = r + 1u) {
        if (lane_reads(i, r, divergent)) {
            acc = acc + fold(table[index(i, r, per_lane)]);
        }
    }
    return acc;
}

fn texel_reads(i: u32, per_lane: bool, divergent: bool) -> u32 {
    var acc = 0u;
    for (var r = 0u; r < READS; r = r + 1u) {
        if (lane_reads(i, r, divergent)) {
            let k = index(i, r, per_lane);
            acc = acc + fold(textureLoad(texels, vec2<u32>(k % SIDE, k / SIDE), 0));
        }
    }
    return acc;
}

@compute @workgroup_size(64)
fn buffer_per_lane(@builtin(global_invocation_id) g: vec3<u32>) { out[g.x] = buffer_reads(g.x, true, false); }
@compute @workgroup_size(64)
fn buffer_uniform(@builtin(global_invocation_id) g: vec3<u32>) { out[g.x] = buffer_reads(g.x, false, false); }
@compute @workgroup_size(64)
fn buffer_divergent(@builtin(global_invocation_id) g: vec3<u32>) { out[g.x] = buffer_reads(g.x, true, true); }
@compute @workgroup_size(64)
fn texture_per_lane(@builtin(global_invocation_id) g: vec3<u32>) { out[g.x] = texel_reads(g.x, true, false); }
@compute @workgroup_size(64)
fn texture_uniform(@builtin(global_invocation_id) g: vec3<u32>) { out[g.x] = texel_reads(g.x, false, false); }
@compute @workgroup_size(64)
fn texture_divergent(@builtin(global_invocation_id) g: vec3<u32>) { out[g.x] = texel_reads(g.x, true, true); }
"#;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let ctx = vplgi_gpu::GpuContext::new()?;
    let (device, queue) = (&ctx.device, &ctx.queue);
    println!("adapter: {}", ctx.describe());
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("load_paths"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    for side in SIDES {
        let words: Vec<u32> =
            (0..side * side * 4).map(|i| i.wrapping_mul(2_654_435_761) ^ (i >> 7)).collect();
        let table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("table"),
            contents: bytemuck::cast_slice(&words),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = wgpu::Extent3d { width: side, height: side, depth_or_array_layers: 1 };
        let texture = device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some("texels"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Uint,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(&words),
        );
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("out"),
            size: INVOCATIONS as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut results = Vec::new();
        for entry in [
            "buffer_per_lane",
            "texture_per_lane",
            "buffer_uniform",
            "texture_uniform",
            "buffer_divergent",
            "texture_divergent",
        ] {
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &[("SIDE", side as f64)],
                    ..Default::default()
                },
                cache: None,
            });
            let layout = pipeline.get_bind_group_layout(0);
            let uses_table = entry.starts_with("buffer");
            let mut entries =
                vec![wgpu::BindGroupEntry { binding: 2, resource: out.as_entire_binding() }];
            entries.push(if uses_table {
                wgpu::BindGroupEntry { binding: 0, resource: table.as_entire_binding() }
            } else {
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&view),
                }
            });
            let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &layout,
                entries: &entries,
            });
            let mut times = Vec::new();
            for _ in 0..6 {
                let t = Instant::now();
                let mut encoder =
                    device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: None,
                        timestamp_writes: None,
                    });
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.dispatch_workgroups(INVOCATIONS / 64, 1, 1);
                }
                queue.submit([encoder.finish()]);
                vplgi_gpu::buffers::sync(device)?;
                times.push(t.elapsed().as_secs_f64());
            }
            times.remove(0); // the first run compiles
            let folded: Vec<u32> =
                vplgi_gpu::buffers::read_back(device, queue, &out, INVOCATIONS as usize)?;
            // The divergent variants read about half the time.
            let reads = INVOCATIONS as f64
                * READS as f64
                * if entry.ends_with("divergent") { 0.5 } else { 1.0 };
            let s = median(times);
            println!(
                "{side:>5}² {entry:>17}: {:8.1} ms, {:7.1} M vec4 reads/s",
                s * 1e3,
                reads / s / 1e6
            );
            results.push(folded);
        }
        let errors = ctx.take_uncaptured_errors();
        if !errors.is_empty() {
            return Err(errors.join("; ").into());
        }
        if results[0] != results[1] || results[2] != results[3] || results[4] != results[5] {
            return Err("a texture variant read other values than its buffer twin".into());
        }
    }
    Ok(())
}
