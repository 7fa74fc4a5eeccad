//! Images for vplgi: the linear HDR [`Image`] type, OpenEXR and PNG I/O, atomic file writes,
//! and the metrics used to compare a render against a reference (MSE, relMSE, LDR-FLIP).
//!
//! Every writer in this crate goes through [`write_atomically`], so a reader (or a crashed run)
//! never sees a half-written file: the target either keeps its old content or gets the new one.

mod atomic;
mod errormap;
mod io;
mod metrics;
pub mod regression;

use std::path::PathBuf;

pub use atomic::write_atomically;
pub use errormap::{error_map_rgb8, write_error_map};
pub use io::{read_exr, resize_rgb8, tonemap_srgb8, write_exr, write_png, write_rgb8_png};
pub use metrics::{compare, excess_change, relative_change, Comparison, Metrics, REL_MSE_EPSILON};

/// A linear HDR RGB image, row-major with row 0 at the top.
///
/// The fields are public for cheap construction and access; every function that consumes an
/// `Image` checks that `pixels.len() == width * height` and reports a mismatch as an error.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance, `pixels[y * width + x]`.
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// A black image of the given size.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, pixels: vec![[0.0; 3]; pixel_count(width, height)] }
    }

    /// The pixel at column `x`, row `y` (row 0 = top), or `None` outside the image.
    pub fn get(&self, x: u32, y: u32) -> Option<[f32; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.pixels.get(self.index(x, y)).copied()
    }

    /// Sets the pixel at column `x`, row `y`; returns `false` (and changes nothing) outside the image.
    pub fn set(&mut self, x: u32, y: u32, rgb: [f32; 3]) -> bool {
        if x >= self.width || y >= self.height {
            return false;
        }
        let i = self.index(x, y);
        match self.pixels.get_mut(i) {
            Some(p) => {
                *p = rgb;
                true
            }
            None => false,
        }
    }

    /// Per-channel mean over all pixels, accumulated in f64; `[0.0; 3]` for an empty image.
    pub fn mean(&self) -> [f64; 3] {
        if self.pixels.is_empty() {
            return [0.0; 3];
        }
        let mut sum = [0.0f64; 3];
        for p in &self.pixels {
            for c in 0..3 {
                sum[c] += f64::from(p[c]);
            }
        }
        let n = self.pixels.len() as f64;
        sum.map(|s| s / n)
    }

    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Checks the public fields are consistent before the image is handed to an encoder or to
    /// FLIP, both of which would otherwise read out of bounds or panic. `what` names the file
    /// (or role) in the error message.
    pub(crate) fn check_len(&self, what: impl Into<String>) -> Result<(), ImageError> {
        check_buffer_len(what, self.width, self.height, 1, self.pixels.len())
    }
}

/// `width * height` as usize; cannot overflow because both factors are u32 and usize is at least
/// 64 bits on every platform this renderer targets.
pub(crate) fn pixel_count(width: u32, height: u32) -> usize {
    width as usize * height as usize
}

/// Errors of this crate. Every message names the file (or, for comparisons, the images
/// involved) and what went wrong.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file could not be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    /// The file (or its temporary sibling) could not be created, written, synced or renamed.
    #[error("cannot write {}: {source}", path.display())]
    Write { path: PathBuf, source: std::io::Error },
    /// The file is not a valid (or supported) OpenEXR file.
    #[error("cannot read {} as OpenEXR: {source}", path.display())]
    Exr { path: PathBuf, source: exr::error::Error },
    /// The EXR file is valid but has no layer with R, G and B channels.
    #[error(
        "{} has no layer with R, G and B channels (channels found: {})",
        path.display(),
        if found.is_empty() { "none".to_string() } else { found.join(", ") }
    )]
    MissingChannels { path: PathBuf, found: Vec<String> },
    /// The EXR header declares more pixels than vplgi reads (a corrupt or hostile header would
    /// otherwise make the decoder allocate them).
    #[error("{} declares a {width}x{height} image; vplgi reads images of at most {max} pixels", path.display())]
    TooLarge { path: PathBuf, width: usize, height: usize, max: usize },
    /// A pixel or byte buffer does not match the stated image size.
    #[error("{what}: buffer holds {actual} values but a {width}x{height} image needs {expected}")]
    BufferSize { what: String, width: u32, height: u32, expected: usize, actual: usize },
    /// The two images of a comparison differ in size.
    #[error(
        "cannot compare images of different sizes: reference is {}x{}, test is {}x{}",
        reference.0, reference.1, test.0, test.1
    )]
    SizeMismatch { reference: (u32, u32), test: (u32, u32) },
    /// The images of a comparison have no pixels, so the metrics (means) are undefined.
    #[error(
        "cannot compare empty ({width}x{height}) images: the metrics are means over no pixels"
    )]
    EmptyComparison { width: u32, height: u32 },
}

/// Checks that a buffer of `actual` values matches a `width` x `height` image with `per_pixel`
/// values per pixel.
pub(crate) fn check_buffer_len(
    what: impl Into<String>,
    width: u32,
    height: u32,
    per_pixel: usize,
    actual: usize,
) -> Result<(), ImageError> {
    let expected = pixel_count(width, height) * per_pixel;
    if actual == expected {
        Ok(())
    } else {
        Err(ImageError::BufferSize { what: what.into(), width, height, expected, actual })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_is_black_and_get_set_respect_bounds() {
        let mut img = Image::new(3, 2);
        assert_eq!(img.pixels.len(), 6);
        assert_eq!(img.get(2, 1), Some([0.0; 3]));
        assert_eq!(img.get(3, 0), None);
        assert_eq!(img.get(0, 2), None);
        assert!(img.set(2, 1, [1.0, 2.0, 3.0]));
        assert!(!img.set(0, 2, [1.0; 3]));
        // Row-major: (2, 1) is the last pixel.
        assert_eq!(img.pixels[5], [1.0, 2.0, 3.0]);
        assert_eq!(img.get(2, 1), Some([1.0, 2.0, 3.0]));
    }

    #[test]
    fn mean_per_channel() {
        let img = Image { width: 2, height: 1, pixels: vec![[1.0, 0.0, 4.0], [3.0, 0.5, 0.0]] };
        assert_eq!(img.mean(), [2.0, 0.25, 2.0]);
        assert_eq!(Image::new(0, 0).mean(), [0.0; 3]);
    }

    #[test]
    fn check_len_reports_mismatch() {
        let img = Image { width: 2, height: 2, pixels: vec![[0.0; 3]; 3] };
        let err = img.check_len("out.exr").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("out.exr") && msg.contains('3') && msg.contains('4'), "{msg}");
    }
}
