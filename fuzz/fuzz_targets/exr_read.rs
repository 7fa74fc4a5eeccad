//! The EXR reader of `vplgi compare` and `vplgi merge` on arbitrary bytes: an image or an error,
//! never a panic; a decoded image then goes through the comparison metrics.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(mut file) = tempfile::NamedTempFile::new() else { return };
    if std::io::Write::write_all(&mut file, data).is_err() {
        return;
    }
    if let Ok(image) = vplgi_image::read_exr(file.path()) {
        // Small images only: the metrics are not what is fuzzed, and FLIP is slow.
        if (image.width as u64) * (image.height as u64) <= 64 * 64 {
            let _ = vplgi_image::compare(&image, &image);
        }
    }
});
