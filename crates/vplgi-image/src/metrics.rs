//! Image comparison metrics: MSE, relative MSE and LDR-FLIP.

use serde::Serialize;

use crate::{tonemap_srgb8, Image, ImageError};

/// The ε in the relative-MSE denominator, `(test − ref)² / (ref² + ε)`. It keeps near-black
/// reference pixels from dominating the mean (and from dividing by zero).
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// Scalar error of a test image against a reference. All three are 0 for identical images.
///
/// Non-finite pixel values propagate: a NaN in either image makes `mse` and `rel_mse` NaN
/// (which serde_json writes as `null`), so a broken render cannot hide behind a small number.
#[derive(Serialize, Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Mean over all pixels and the 3 channels of `(test − ref)²`, on the linear HDR values.
    pub mse: f64,
    /// Mean over all pixels and the 3 channels of `(test − ref)² / (ref² + ε)` with
    /// ε = [`REL_MSE_EPSILON`] = 0.01, on the linear HDR values.
    pub rel_mse: f64,
    /// Mean of the LDR-FLIP error map (in [0, 1]) computed by the `nv-flip` crate (NVIDIA's
    /// FLIP, default 67 pixels per degree) on both images tonemapped with
    /// [`tonemap_srgb8`]`(.., 1.0)`.
    pub flip: f64,
    /// Per channel, the test's sum over all pixels divided by the reference's: the energy the
    /// test keeps (1: none lost or added; NaN where the reference's channel sums to 0).
    pub mean_ratio: [f64; 3],
}

/// The result of [`compare`]: the scalar metrics plus the per-pixel FLIP error map.
#[derive(Clone, Debug)]
pub struct Comparison {
    pub metrics: Metrics,
    pub width: u32,
    pub height: u32,
    /// Per-pixel LDR-FLIP error in [0, 1], row-major, row 0 = top; its mean is `metrics.flip`.
    pub flip_error: Vec<f32>,
}

/// Compares `test` against `reference` (see [`Metrics`] for the exact definitions).
///
/// Errors if the images differ in size, are empty (the metrics are means), or have a pixel
/// buffer that does not match their stated size.
pub fn compare(reference: &Image, test: &Image) -> Result<Comparison, ImageError> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(ImageError::SizeMismatch {
            reference: (reference.width, reference.height),
            test: (test.width, test.height),
        });
    }
    reference.check_len("reference image")?;
    test.check_len("test image")?;
    if reference.pixels.is_empty() {
        return Err(ImageError::EmptyComparison {
            width: reference.width,
            height: reference.height,
        });
    }

    // Accumulate in f64: a 4K image has ~25M terms, too many for an f32 sum.
    let mut squared = 0.0f64;
    let mut relative = 0.0f64;
    let (mut sum_ref, mut sum_test) = ([0.0f64; 3], [0.0f64; 3]);
    for (r, t) in reference.pixels.iter().zip(&test.pixels) {
        for c in 0..3 {
            let (r, t) = (f64::from(r[c]), f64::from(t[c]));
            let d = t - r;
            squared += d * d;
            relative += d * d / (r * r + REL_MSE_EPSILON);
            sum_ref[c] += r;
            sum_test[c] += t;
        }
    }
    let mean_ratio =
        [0, 1, 2].map(|c| if sum_ref[c] == 0.0 { f64::NAN } else { sum_test[c] / sum_ref[c] });
    let samples = (reference.pixels.len() * 3) as f64;

    let flip_error = ldr_flip(reference, test);
    // The mean is taken here in f64 rather than with `nv_flip::FlipPool`, which sums in f32.
    let flip = flip_error.iter().map(|&e| f64::from(e)).sum::<f64>() / flip_error.len() as f64;

    Ok(Comparison {
        metrics: Metrics { mse: squared / samples, rel_mse: relative / samples, flip, mean_ratio },
        width: reference.width,
        height: reference.height,
        flip_error,
    })
}

/// The LDR-FLIP error map of two same-sized, consistent, non-empty images (checked by
/// [`compare`]), after the fixed sRGB tonemap at exposure 1.
fn ldr_flip(reference: &Image, test: &Image) -> Vec<f32> {
    let to_flip = |img: &Image| {
        nv_flip::FlipImageRgb8::with_data(img.width, img.height, &tonemap_srgb8(img, 1.0))
    };
    nv_flip::flip(to_flip(reference), to_flip(test), nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec()
}

/// How much an image changed from the frame before: the summed absolute change of every pixel
/// and channel over the previous frame's sum (a relative L1 change; 0.1 is "10 % of the light
/// moved"). A sequence's flicker is its mean over consecutive frames; camera motion changes images
/// too, so it is read against the same measure of a converged sequence along the same path.
pub fn relative_change(previous: &Image, next: &Image) -> Result<f64, ImageError> {
    if (previous.width, previous.height) != (next.width, next.height) {
        return Err(ImageError::SizeMismatch {
            reference: (previous.width, previous.height),
            test: (next.width, next.height),
        });
    }
    previous.check_len("previous frame")?;
    next.check_len("next frame")?;
    let (mut change, mut total) = (0.0f64, 0.0f64);
    for (a, b) in previous.pixels.iter().zip(&next.pixels) {
        for c in 0..3 {
            change += (f64::from(b[c]) - f64::from(a[c])).abs();
            total += f64::from(a[c]);
        }
    }
    Ok(if total > 0.0 {
        change / total
    } else if change == 0.0 {
        0.0
    } else {
        f64::INFINITY
    })
}

/// The change between two frames that a converged sequence along the same path does not have:
/// the summed absolute difference of the two changes, over the converged previous frame's sum.
/// Camera motion changes both sequences alike and cancels; what is left is the approximation's
/// own change from frame to frame (its flicker), 0 for a sequence that changes exactly as the
/// converged one does.
pub fn excess_change(
    previous: &Image,
    next: &Image,
    (ref_previous, ref_next): (&Image, &Image),
) -> Result<f64, ImageError> {
    for (what, img) in [
        ("next frame", next),
        ("converged previous frame", ref_previous),
        ("converged next frame", ref_next),
    ] {
        if (img.width, img.height) != (previous.width, previous.height) {
            return Err(ImageError::SizeMismatch {
                reference: (previous.width, previous.height),
                test: (img.width, img.height),
            });
        }
        img.check_len(what)?;
    }
    previous.check_len("previous frame")?;
    let (mut excess, mut total) = (0.0f64, 0.0f64);
    for (((a, b), ra), rb) in
        previous.pixels.iter().zip(&next.pixels).zip(&ref_previous.pixels).zip(&ref_next.pixels)
    {
        for c in 0..3 {
            let change = f64::from(b[c]) - f64::from(a[c]);
            let converged = f64::from(rb[c]) - f64::from(ra[c]);
            excess += (change - converged).abs();
            total += f64::from(ra[c]);
        }
    }
    Ok(if total > 0.0 {
        excess / total
    } else if excess == 0.0 {
        0.0
    } else {
        f64::INFINITY
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Motion shared with the converged sequence cancels; a change of its own remains.
    #[test]
    fn excess_change_is_what_the_converged_sequence_does_not_do() {
        let a = pattern(16, 8);
        let moved = Image { pixels: a.pixels.iter().rev().copied().collect(), ..a.clone() };
        assert_eq!(excess_change(&a, &moved, (&a, &moved)).unwrap(), 0.0);
        // The approximation brightens by 10 % where the converged one only moved.
        let brighter = Image {
            pixels: moved.pixels.iter().map(|p| p.map(|c| 1.1 * c)).collect(),
            ..a.clone()
        };
        assert!((excess_change(&a, &brighter, (&a, &moved)).unwrap() - 0.1).abs() < 1e-6);
        // An approximation that stands still while the converged one moves has its motion as excess.
        assert_eq!(
            excess_change(&a, &a, (&a, &moved)).unwrap(),
            relative_change(&a, &moved).unwrap()
        );
        assert!(excess_change(&a, &a, (&a, &filled(2, 2, [1.0; 3]))).is_err());
    }

    #[test]
    fn relative_change_is_the_l1_change_over_the_previous_sum() {
        let img = pattern(16, 8);
        assert_eq!(relative_change(&img, &img).unwrap(), 0.0);
        let brighter = Image {
            pixels: img.pixels.iter().map(|p| p.map(|c| 1.25 * c)).collect(),
            ..img.clone()
        };
        assert!((relative_change(&img, &brighter).unwrap() - 0.25).abs() < 1e-6);
        // Light moving between pixels counts once where it left and once where it arrived.
        let a = Image { width: 2, height: 1, pixels: vec![[1.0; 3], [0.0; 3]] };
        let b = Image { width: 2, height: 1, pixels: vec![[0.0; 3], [1.0; 3]] };
        assert_eq!(relative_change(&a, &b).unwrap(), 2.0);
        let black = filled(2, 1, [0.0; 3]);
        assert_eq!(relative_change(&black, &black).unwrap(), 0.0);
        assert!(relative_change(&img, &filled(4, 4, [0.0; 3])).is_err());
    }

    fn filled(width: u32, height: u32, rgb: [f32; 3]) -> Image {
        Image { width, height, pixels: vec![rgb; (width * height) as usize] }
    }

    /// A reference with some structure (gradient + checker), so FLIP sees edges too.
    fn pattern(width: u32, height: u32) -> Image {
        let mut img = Image::new(width, height);
        for y in 0..height {
            for x in 0..width {
                let checker = if (x / 4 + y / 4) % 2 == 0 { 0.1 } else { 0.0 };
                let v = 0.05 + 0.3 * x as f32 / width as f32 + checker;
                img.set(x, y, [v, 0.8 * v, 0.5 * v]);
            }
        }
        img
    }

    fn offset(img: &Image, delta: f32) -> Image {
        Image { pixels: img.pixels.iter().map(|p| p.map(|c| c + delta)).collect(), ..img.clone() }
    }

    #[test]
    fn identical_images_have_zero_error() {
        let img = pattern(32, 24);
        let cmp = compare(&img, &img.clone()).expect("compare");
        assert_eq!(cmp.metrics.mse, 0.0);
        assert_eq!(cmp.metrics.rel_mse, 0.0);
        assert_eq!(cmp.metrics.flip, 0.0);
        assert_eq!(cmp.metrics.mean_ratio, [1.0; 3]);
        assert_eq!((cmp.width, cmp.height), (32, 24));
        assert_eq!(cmp.flip_error.len(), 32 * 24);
        assert!(cmp.flip_error.iter().all(|&e| e == 0.0));
    }

    #[test]
    fn known_offsets_give_hand_computed_mse_and_rel_mse() {
        // Uniform: ref 0.5, test 0.75 => d² = 0.0625 everywhere;
        // rel = 0.0625 / (0.25 + 0.01).
        let cmp = compare(&filled(4, 3, [0.5; 3]), &filled(4, 3, [0.75; 3])).expect("compare");
        assert!((cmp.metrics.mse - 0.0625).abs() < 1e-12, "{:?}", cmp.metrics);
        assert!((cmp.metrics.rel_mse - 0.0625 / 0.26).abs() < 1e-12, "{:?}", cmp.metrics);

        // Per channel and per pixel: the mean runs over pixels and channels.
        // pixel 0: ref [0, 1, 2], test [1, 1, 2.5] => d² = [1, 0, 0.25],
        //          rel = [1/0.01, 0, 0.25/4.01]
        // pixel 1: ref [3, 0, 0], test [3, 0, 0]   => all 0
        let reference =
            Image { width: 2, height: 1, pixels: vec![[0.0, 1.0, 2.0], [3.0, 0.0, 0.0]] };
        let test = Image { width: 2, height: 1, pixels: vec![[1.0, 1.0, 2.5], [3.0, 0.0, 0.0]] };
        let cmp = compare(&reference, &test).expect("compare");
        let mse = (1.0 + 0.25) / 6.0;
        let rel_mse = (1.0 / 0.01 + 0.25 / 4.01) / 6.0;
        assert!((cmp.metrics.mse - mse).abs() < 1e-12, "{:?}", cmp.metrics);
        assert!((cmp.metrics.rel_mse - rel_mse).abs() < 1e-12, "{:?}", cmp.metrics);
        // Sums per channel: R 4 / 3, G 1 / 1, B 2.5 / 2.
        assert_eq!(cmp.metrics.mean_ratio, [4.0 / 3.0, 1.0, 1.25]);
        let black = compare(&filled(2, 2, [0.0; 3]), &filled(2, 2, [0.5; 3])).expect("compare");
        assert!(black.metrics.mean_ratio.iter().all(|r| r.is_nan()));
    }

    #[test]
    fn flip_grows_with_the_difference() {
        let reference = pattern(48, 32);
        let small = compare(&reference, &offset(&reference, 0.05)).expect("compare small");
        let large = compare(&reference, &offset(&reference, 0.4)).expect("compare large");
        let (s, l) = (small.metrics.flip, large.metrics.flip);
        assert!(s > 0.0, "a visible offset must give FLIP > 0, got {s}");
        assert!(l > s, "larger difference must give larger FLIP: {s} vs {l}");
        assert!(l <= 1.0, "FLIP is in [0, 1], got {l}");
        assert!(large.flip_error.iter().all(|e| (0.0..=1.0).contains(e)));
        assert!(large.metrics.mse > small.metrics.mse);
    }

    #[test]
    fn flip_mean_agrees_with_nv_flip_pool() {
        let reference = pattern(40, 40);
        let test = offset(&reference, 0.15);
        let cmp = compare(&reference, &test).expect("compare");
        let map = nv_flip::FlipImageFloat::with_data(40, 40, &cmp.flip_error);
        let pool_mean = f64::from(nv_flip::FlipPool::from_image(&map).mean());
        assert!((cmp.metrics.flip - pool_mean).abs() < 1e-5, "{} vs {pool_mean}", cmp.metrics.flip);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let err = compare(&Image::new(4, 4), &Image::new(4, 5)).unwrap_err();
        assert!(matches!(err, ImageError::SizeMismatch { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("4x4") && msg.contains("4x5"), "{msg}");
    }

    #[test]
    fn empty_and_inconsistent_images_are_errors() {
        let err = compare(&Image::new(0, 3), &Image::new(0, 3)).unwrap_err();
        assert!(matches!(err, ImageError::EmptyComparison { .. }), "{err:?}");

        let broken = Image { width: 2, height: 2, pixels: vec![[0.0; 3]; 3] };
        let err = compare(&Image::new(2, 2), &broken).unwrap_err();
        assert!(err.to_string().contains("test image"), "{err}");
    }

    #[test]
    fn metrics_serialize_with_field_names() {
        let m = Metrics { mse: 0.5, rel_mse: 0.25, flip: 0.125, mean_ratio: [1.0, 0.5, 2.0] };
        let json = serde_json::to_value(m).expect("serialize");
        assert_eq!(
            json,
            serde_json::json!({"mse": 0.5, "rel_mse": 0.25, "flip": 0.125, "mean_ratio": [1.0, 0.5, 2.0]})
        );
    }
}
