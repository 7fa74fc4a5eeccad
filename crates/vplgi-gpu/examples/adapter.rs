//! Prints the adapter vplgi would use, its features and the limits that shape the kernels.
//!
//! Run: `cargo run --release -p vplgi-gpu --example adapter`
fn main() {
    match vplgi_gpu::GpuContext::new() {
        Ok(ctx) => {
            let l = ctx.device.limits();
            println!("adapter: {} ({:?})", ctx.describe(), ctx.info.device_type);
            println!("features: {:?}", ctx.adapter.features());
            println!(
                "max storage binding {} B, max buffer {} B, storage offset alignment {} B, storage buffers per stage {}, workgroups per dimension {}, invocations per workgroup {}",
                l.max_storage_buffer_binding_size, l.max_buffer_size, l.min_storage_buffer_offset_alignment, l.max_storage_buffers_per_shader_stage, l.max_compute_workgroups_per_dimension, l.max_compute_invocations_per_workgroup
            );
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
