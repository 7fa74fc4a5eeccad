//! OpenEXR reading/writing, the fixed sRGB tonemap, and PNG writing.

use std::fs::File;
use std::io::{self, BufReader, Seek};
use std::path::Path;

use exr::prelude::{
    Encoding, Layer, LayerAttributes, MetaData, ReadChannels, ReadLayers, ReadSpecificChannel,
    SpecificChannels, Vec2, WritableImage,
};
use image::{ExtendedColorType, ImageEncoder};

use crate::{check_buffer_len, pixel_count, write_atomically, Image, ImageError};

/// Writes `img` as a single-layer OpenEXR file with 32-bit float R, G, B channels (lossless
/// ZIP compression, so reading it back with [`read_exr`] is bit-exact), atomically
/// (see [`write_atomically`]).
pub fn write_exr(path: &Path, img: &Image) -> Result<(), ImageError> {
    img.check_len(path.display().to_string())?;
    let width = img.width as usize;
    // `check_len` guarantees every position inside the layer size indexes a pixel.
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let [r, g, b] = img.pixels[pos.y() * width + pos.x()];
        (r, g, b)
    });
    let layer = Layer::new(
        (width, img.height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let exr_image = exr::image::Image::from_layer(layer);
    write_atomically(path, |out| {
        exr_image.write().to_buffered(out).map_err(|e| match e {
            // Keep the OS error as is (e.g. "No space left on device").
            exr::error::Error::Io(io_err) => io_err,
            other => io::Error::other(other),
        })
    })
}

/// The largest image [`read_exr`] decodes: 8192 x 8192 pixels (768 MiB of RGB floats).
pub const MAX_EXR_PIXELS: usize = 1 << 26;

/// Reads the first layer of an OpenEXR file that has R, G and B channels (any of f16, f32 or
/// u32 samples, converted to f32; other channels such as A are ignored). The image covers the
/// layer's data window, row 0 at the top.
///
/// Errors name the path: [`ImageError::Read`] if the file cannot be opened, [`ImageError::Exr`]
/// if it is not a valid OpenEXR file, [`ImageError::MissingChannels`] if no layer has R, G and B,
/// [`ImageError::TooLarge`] if a layer declares more than [`MAX_EXR_PIXELS`].
pub fn read_exr(path: &Path) -> Result<Image, ImageError> {
    let read_err = |source: io::Error| ImageError::Read { path: path.to_path_buf(), source };
    let exr_err = |source: exr::error::Error| ImageError::Exr { path: path.to_path_buf(), source };
    let mut reader = BufReader::new(File::open(path).map_err(read_err)?);

    // Look at the headers first: the exr crate only says "no layer matched your requirements"
    // when the channels are missing, and the user deserves to know which channels exist.
    let meta = MetaData::read_from_buffered(&mut reader, false).map_err(exr_err)?;
    let has_rgb = meta.headers.iter().any(|header| {
        !header.deep
            && ["R", "G", "B"]
                .iter()
                .all(|name| header.channels.list.iter().any(|c| c.name.eq(name)))
    });
    if !has_rgb {
        let mut found: Vec<String> = Vec::new();
        for header in &meta.headers {
            for channel in &header.channels.list {
                let name = channel.name.to_string();
                if !found.contains(&name) {
                    found.push(name);
                }
            }
        }
        return Err(ImageError::MissingChannels { path: path.to_path_buf(), found });
    }
    // Found by fuzzing: a header declaring billions of pixels made the decoder allocate them.
    if let Some(h) = meta
        .headers
        .iter()
        .find(|h| h.layer_size.width().saturating_mul(h.layer_size.height()) > MAX_EXR_PIXELS)
    {
        return Err(ImageError::TooLarge {
            path: path.to_path_buf(),
            width: h.layer_size.width(),
            height: h.layer_size.height(),
            max: MAX_EXR_PIXELS,
        });
    }
    reader.rewind().map_err(read_err)?;

    let exr_image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("R")
        .required("G")
        .required("B")
        .collect_pixels(
            |size: Vec2<usize>, _| (size.x(), vec![[0.0f32; 3]; size.area()]),
            |(width, pixels): &mut (usize, Vec<[f32; 3]>),
             pos: Vec2<usize>,
             (r, g, b): (f32, f32, f32)| {
                // Positions are always inside the layer; `get_mut` just keeps a corrupt file
                // from turning into a panic.
                if let Some(p) = pixels.get_mut(pos.y() * *width + pos.x()) {
                    *p = [r, g, b];
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(reader)
        .map_err(exr_err)?;

    let layer = exr_image.layer_data;
    // The EXR format stores sizes as i32, so these conversions only fail on a corrupt header.
    let too_large = || {
        exr_err(exr::error::Error::NotSupported("image larger than 2^32 pixels per side".into()))
    };
    let width = u32::try_from(layer.size.x()).map_err(|_| too_large())?;
    let height = u32::try_from(layer.size.y()).map_err(|_| too_large())?;
    let (_, pixels) = layer.channel_data.pixels;
    debug_assert_eq!(pixels.len(), pixel_count(width, height));
    Ok(Image { width, height, pixels })
}

/// The fixed tonemap of vplgi: linear RGB -> 8-bit sRGB, tightly packed RGB8, row-major.
///
/// Each channel is multiplied by `exposure`, clamped to [0, 1] (NaN and negative values become
/// 0, +inf becomes 1), encoded with the exact sRGB OETF (12.92·v below 0.0031308, otherwise
/// 1.055·v^(1/2.4) − 0.055, evaluated in f64) and rounded to the nearest of 0..=255.
///
/// This is the only tonemap used for PNG output ([`write_png`]) and, with `exposure = 1`, for
/// the LDR-FLIP metric ([`crate::compare`]), so PNGs and FLIP scores always agree.
pub fn tonemap_srgb8(img: &Image, exposure: f32) -> Vec<u8> {
    img.pixels.iter().flat_map(|p| p.map(|c| srgb8(c * exposure))).collect()
}

fn srgb8(linear: f32) -> u8 {
    // `linear > 0.0` is false for NaN, which therefore maps to 0 like negative values.
    let v = if linear > 0.0 { f64::from(linear).min(1.0) } else { 0.0 };
    let encoded = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    // `encoded` is within [0, 1], so the rounded value fits in u8.
    (encoded * 255.0).round() as u8
}

/// Writes `img` as an 8-bit sRGB PNG using [`tonemap_srgb8`] with `exposure`, atomically.
pub fn write_png(path: &Path, img: &Image, exposure: f32) -> Result<(), ImageError> {
    img.check_len(path.display().to_string())?;
    write_rgb8_png(path, img.width, img.height, &tonemap_srgb8(img, exposure))
}

/// Writes tightly packed, row-major RGB8 bytes (`width * height * 3` of them) as a PNG,
/// atomically.
pub fn write_rgb8_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), ImageError> {
    check_buffer_len(path.display().to_string(), width, height, 3, rgb.len())?;
    write_atomically(path, |out| {
        image::codecs::png::PngEncoder::new(out)
            .write_image(rgb, width, height, ExtendedColorType::Rgb8)
            .map_err(io::Error::other)
    })
}

/// `src` (`w` x `h` 8-bit RGB rows) resized to `to` by averaging the source pixels each target
/// pixel covers (at least one): thumbnails and contact sheets.
pub fn resize_rgb8(src: &[u8], (w, h): (u32, u32), to: (u32, u32)) -> Vec<u8> {
    let span = |i: u32, n: u32, of: u32| {
        let a = i as u64 * of as u64 / n as u64;
        (a, ((i as u64 + 1) * of as u64 / n as u64).max(a + 1).min(of as u64))
    };
    let mut out = Vec::with_capacity((to.0 * to.1 * 3) as usize);
    for y in 0..to.1 {
        let (y0, y1) = span(y, to.1, h);
        for x in 0..to.0 {
            let (x0, x1) = span(x, to.0, w);
            let mut sum = [0u64; 3];
            for sy in y0..y1 {
                for sx in x0..x1 {
                    let i = ((sy * w as u64 + sx) * 3) as usize;
                    for c in 0..3 {
                        sum[c] += src[i + c] as u64;
                    }
                }
            }
            let n = ((y1 - y0) * (x1 - x0)).max(1);
            out.extend(sum.map(|s| (s / n) as u8));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use exr::prelude::{f16, WritableImage};

    /// A non-square image whose values include 0, -0, values > 1, tiny and huge ones, with a
    /// different value per position so that any transposition or flip is caught.
    fn sample_image() -> Image {
        let specials = [0.0f32, -0.0, 1.0, 1.5, 7.25, 65504.0, 1.0e-8, 3.0e38, 0.1];
        let mut img = Image::new(5, 3);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let s = specials[i % specials.len()];
            *p = [s, i as f32 * 0.37 + 2.0, (i as f32).sqrt() * 0.01];
        }
        img
    }

    fn bits(img: &Image) -> Vec<[u32; 3]> {
        img.pixels.iter().map(|p| p.map(f32::to_bits)).collect()
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("img.exr");
        let img = sample_image();
        write_exr(&path, &img).expect("write exr");
        let back = read_exr(&path).expect("read exr");
        assert_eq!((back.width, back.height), (5, 3));
        assert_eq!(bits(&back), bits(&img));
        // Only the target is left in the directory.
        let names: Vec<_> = std::fs::read_dir(dir.path()).expect("ls").collect();
        assert_eq!(names.len(), 1);
    }

    #[test]
    fn exr_write_rejects_inconsistent_image() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("bad.exr");
        let img = Image { width: 4, height: 4, pixels: vec![[1.0; 3]; 5] };
        let err = write_exr(&path, &img).unwrap_err();
        assert!(err.to_string().contains("bad.exr"), "{err}");
        assert!(!path.exists());
    }

    #[test]
    fn reads_f16_rgba_and_u32_rgb_files() {
        let dir = tempfile::tempdir().expect("tempdir");

        // f16 RGBA: alpha is ignored, halves convert exactly.
        let half_path = dir.path().join("half.exr");
        exr::prelude::write_rgba_file(&half_path, 3, 2, |x, y| {
            let v = f16::from_f32((x + 10 * y) as f32 * 0.5);
            (v, v, f16::from_f32(2.0), f16::from_f32(0.25))
        })
        .expect("write f16 rgba");
        let img = read_exr(&half_path).expect("read f16");
        assert_eq!((img.width, img.height), (3, 2));
        assert_eq!(img.get(2, 1), Some([6.0, 6.0, 2.0]));
        assert_eq!(img.get(1, 0), Some([0.5, 0.5, 2.0]));

        // u32 RGB.
        let uint_path = dir.path().join("uint.exr");
        exr::prelude::write_rgb_file(&uint_path, 2, 2, |x, y| (x as u32, y as u32, 7u32))
            .expect("write u32 rgb");
        let img = read_exr(&uint_path).expect("read u32");
        assert_eq!(img.get(1, 0), Some([1.0, 0.0, 7.0]));
        assert_eq!(img.get(0, 1), Some([0.0, 1.0, 7.0]));
    }

    #[test]
    fn exr_without_rgb_names_path_and_channels() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("luma.exr");
        let channels = SpecificChannels::build()
            .with_channel("Y")
            .with_pixel_fn(|_pos: Vec2<usize>| (0.5f32,));
        let layer =
            Layer::new((2, 2), LayerAttributes::default(), Encoding::UNCOMPRESSED, channels);
        exr::image::Image::from_layer(layer).write().to_file(&path).expect("write luma exr");
        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, ImageError::MissingChannels { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("luma.exr") && msg.contains('Y'), "{msg}");
    }

    /// A header that declares more pixels than `MAX_EXR_PIXELS` is refused before the decoder
    /// allocates them, with an error naming the file and the declared size. Made by writing a
    /// 5x3 image and rewriting its data window to 10000 x 10000.
    #[test]
    fn exr_declaring_too_many_pixels_is_refused_before_decoding() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("huge.exr");
        write_exr(&path, &sample_image()).expect("write exr");
        let mut bytes = std::fs::read(&path).expect("read back");
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).expect("a dataWindow attribute")
            + key.len()
            + 4;
        for (i, v) in [0i32, 0, 9999, 9999].into_iter().enumerate() {
            bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
        }
        std::fs::write(&path, bytes).expect("rewrite");
        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, ImageError::TooLarge { width: 10000, height: 10000, .. }), "{err:?}");
        assert!(
            err.to_string().contains("huge.exr") && err.to_string().contains("10000x10000"),
            "{err}"
        );
    }

    #[test]
    fn missing_exr_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("does-not-exist.exr");
        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, ImageError::Read { .. }), "{err:?}");
        assert!(err.to_string().contains("does-not-exist.exr"), "{err}");
    }

    #[test]
    fn garbage_exr_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().expect("tempdir");
        for (name, content) in [
            ("garbage.exr", b"this is not an OpenEXR file at all".to_vec()),
            ("empty.exr", Vec::new()),
            // Valid magic number, then nonsense.
            ("truncated.exr", vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, b'x']),
        ] {
            let path = dir.path().join(name);
            std::fs::write(&path, content).expect("write garbage");
            let err = read_exr(&path).unwrap_err();
            assert!(matches!(err, ImageError::Exr { .. }), "{name}: {err:?}");
            assert!(err.to_string().contains(name), "{err}");
        }
    }

    #[test]
    fn tonemap_known_values() {
        let img = Image {
            width: 8,
            height: 1,
            pixels: vec![
                [0.0, 1.0, 0.5],
                [-1.0, f32::NAN, f32::NEG_INFINITY],
                [2.0, f32::INFINITY, 0.001],
                // 0.0031308 is the OETF's knee: 12.92 * 0.0031308 * 255 = 10.3.
                [0.003_130_8, 0.214, 0.18],
                [0.0; 3],
                [0.0; 3],
                [0.0; 3],
                [0.0; 3],
            ],
        };
        let bytes = tonemap_srgb8(&img, 1.0);
        assert_eq!(bytes.len(), 8 * 3);
        assert_eq!(&bytes[0..3], &[0, 255, 188]);
        assert_eq!(&bytes[3..6], &[0, 0, 0]);
        // 0.001 * 12.92 * 255 = 3.29 -> 3.
        assert_eq!(&bytes[6..9], &[255, 255, 3]);
        // 10.31 -> 10; 0.214 -> 127.49 -> 127; 0.18 (middle grey) -> 117.65 -> 118.
        assert_eq!(&bytes[9..12], &[10, 127, 118]);

        // Exposure scales before the clamp; NaN exposure gives black rather than garbage.
        assert_eq!(&tonemap_srgb8(&img, 2.0)[0..3], &[0, 255, 255]);
        assert_eq!(&tonemap_srgb8(&img, 0.25)[0..3], &[0, 137, 99]);
        assert!(tonemap_srgb8(&img, f32::NAN).iter().all(|&b| b == 0));
    }

    #[test]
    fn png_round_trip_matches_tonemap() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("img.png");
        let img = sample_image();
        write_png(&path, &img, 0.5).expect("write png");
        let decoded = image::open(&path).expect("decode png").into_rgb8();
        assert_eq!((decoded.width(), decoded.height()), (5, 3));
        assert_eq!(decoded.into_raw(), tonemap_srgb8(&img, 0.5));
    }

    #[test]
    fn rgb8_png_rejects_wrong_length_without_creating_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("short.png");
        let err = write_rgb8_png(&path, 2, 2, &[0u8; 11]).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("short.png") && msg.contains("11") && msg.contains("12"), "{msg}");
        assert!(!path.exists());
    }
}
