//! Decoding glTF images to linear RGB texels.

use crate::{srgb_to_linear, Texture};
use glam::Vec3;

/// Decodes an image to linear RGB texels. 8- and 16-bit data is sRGB-encoded (glTF base colour
/// textures always are); float data can only come from formats that store linear values. Grey
/// images spread over all three channels; alpha is dropped.
pub(super) fn linear_texture(data: &gltf::image::Data) -> Result<Texture, String> {
    use gltf::image::Format;
    let (channels, bytes_per_channel) = match data.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let (w, h) = (data.width as usize, data.height as usize);
    if w == 0 || h == 0 {
        return Err("the image is empty".into());
    }
    let pixel_bytes = channels * bytes_per_channel;
    if w.checked_mul(h).and_then(|n| n.checked_mul(pixel_bytes)) != Some(data.pixels.len()) {
        return Err(format!(
            "{} bytes of pixels for a {w}x{h} {:?} image",
            data.pixels.len(),
            data.format
        ));
    }
    // Decoding 8-bit data through a table is exact and avoids millions of powf calls.
    let table = crate::srgb8_table();
    let channel = |c: &[u8]| -> f32 {
        match bytes_per_channel {
            1 => table[c[0] as usize],
            // The image crate hands out 16- and 32-bit samples in native byte order.
            2 => srgb_to_linear(u16::from_ne_bytes([c[0], c[1]]) as f32 / 65535.0),
            _ => f32::from_ne_bytes([c[0], c[1], c[2], c[3]]),
        }
    };
    let texels = data
        .pixels
        .chunks_exact(pixel_bytes)
        .map(|p| {
            let grey = || Vec3::splat(channel(&p[..bytes_per_channel]));
            match channels {
                1 | 2 => grey(),
                _ => Vec3::new(
                    channel(&p[..bytes_per_channel]),
                    channel(&p[bytes_per_channel..2 * bytes_per_channel]),
                    channel(&p[2 * bytes_per_channel..3 * bytes_per_channel]),
                ),
            }
        })
        .collect();
    Ok(Texture { width: data.width, height: data.height, texels })
}
