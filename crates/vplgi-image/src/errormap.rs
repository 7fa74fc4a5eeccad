//! False-colour visualisation of the FLIP error map.

use std::path::Path;

use crate::{check_buffer_len, write_rgb8_png, Comparison, ImageError};

/// Writes the per-pixel FLIP error of `cmp` as a PNG in FLIP's magma colour map (black = no
/// error, through purple and orange, to pale yellow = error 1), atomically.
pub fn write_error_map(path: &Path, cmp: &Comparison) -> Result<(), ImageError> {
    let rgb = error_map_rgb8(&path.display().to_string(), cmp)?;
    write_rgb8_png(path, cmp.width, cmp.height, &rgb)
}

/// The per-pixel FLIP error of `cmp` in FLIP's magma colour map, as 8-bit RGB rows (`what` names
/// the comparison in errors).
pub fn error_map_rgb8(what: &str, cmp: &Comparison) -> Result<Vec<u8>, ImageError> {
    // The fields are public: check them, because nv-flip panics on a short buffer.
    check_buffer_len(what.to_string(), cmp.width, cmp.height, 1, cmp.flip_error.len())?;
    let map = nv_flip::FlipImageFloat::with_data(cmp.width, cmp.height, &cmp.flip_error);
    Ok(map.apply_color_lut(&nv_flip::magma_lut()).to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{compare, Image};

    fn decode(path: &Path) -> image::RgbImage {
        image::open(path).expect("decode error map").into_rgb8()
    }

    #[test]
    fn identical_images_map_to_magma_zero() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("flip.png");
        let img =
            Image { width: 6, height: 4, pixels: (0..24).map(|i| [i as f32 / 24.0; 3]).collect() };
        let cmp = compare(&img, &img).expect("compare");
        write_error_map(&path, &cmp).expect("write error map");
        let png = decode(&path);
        assert_eq!((png.width(), png.height()), (6, 4));
        let lut = nv_flip::magma_lut().to_vec();
        assert!(png.pixels().all(|p| p.0 == [lut[0], lut[1], lut[2]]));
        assert_eq!(std::fs::read_dir(dir.path()).expect("ls").count(), 1);
    }

    #[test]
    fn differing_half_is_brighter_in_the_map() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("flip.png");
        let reference = Image { width: 32, height: 16, pixels: vec![[0.2; 3]; 32 * 16] };
        // Only the right half differs.
        let mut test = reference.clone();
        for y in 0..16 {
            for x in 16..32 {
                test.set(x, y, [0.9, 0.1, 0.1]);
            }
        }
        let cmp = compare(&reference, &test).expect("compare");
        write_error_map(&path, &cmp).expect("write error map");
        let png = decode(&path);
        let brightness =
            |x: u32, y: u32| png.get_pixel(x, y).0.iter().map(|&c| u32::from(c)).sum::<u32>();
        // Away from the edge, where FLIP's spatial filters blur the difference.
        assert!(brightness(28, 8) > brightness(2, 8) + 100);
    }

    #[test]
    fn inconsistent_comparison_is_an_error() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("bad.png");
        let mut cmp = compare(&Image::new(2, 2), &Image::new(2, 2)).expect("compare");
        cmp.flip_error.pop();
        let err = write_error_map(&path, &cmp).unwrap_err();
        assert!(err.to_string().contains("bad.png"), "{err}");
        assert!(!path.exists());
    }
}
