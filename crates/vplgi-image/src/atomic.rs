//! Atomic file replacement: write a temporary sibling, fsync it, rename it over the target.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::ImageError;

/// Distinguishes temporary files of concurrent writes from the same process (the pid alone
/// would make two threads writing the same target share, and corrupt, one temporary file).
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: `write` fills a temporary file `.<name>.tmp-<pid>-<n>` in the same
/// directory (same directory = same filesystem, so the final rename is atomic), which is then
/// flushed, fsynced and renamed over `path`.
///
/// If `write` (or any later step) fails, or panics, the temporary file is removed and `path` is
/// left untouched: it keeps its old content, or stays absent if it did not exist.
/// Errors are reported as [`ImageError::Write`] naming `path`.
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>) -> Result<(), ImageError> {
    let wrap = |source: io::Error| ImageError::Write { path: path.to_path_buf(), source };
    let file_name = path.file_name().ok_or_else(|| wrap(io::Error::new(io::ErrorKind::InvalidInput, "the path does not name a file")))?;
    // `Path::parent` of a bare file name is "", which means the current directory.
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(file_name);
    temp_name.push(format!(".tmp-{}-{}", std::process::id(), TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)));
    let mut guard = TempGuard { path: dir.join(temp_name), renamed: false };

    // Truncate rather than create_new: a leftover with exactly this name can only come from a
    // dead process that had our pid, and it is ours to overwrite.
    let file = OpenOptions::new().write(true).create(true).truncate(true).open(&guard.path).map_err(wrap)?;
    let mut writer = BufWriter::new(file);
    write(&mut writer).map_err(wrap)?;
    let file = writer.into_inner().map_err(|e| wrap(e.into_error()))?;
    file.sync_all().map_err(wrap)?;
    drop(file);
    fs::rename(&guard.path, path).map_err(wrap)?;
    // The rename consumed the temporary file: removing its old name now could only hit an
    // unrelated file created since.
    guard.renamed = true;

    // Make the rename itself durable. Best effort: some platforms cannot open or sync a
    // directory, and the file content is already safely on disk either way.
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Removes the temporary file when dropped, so that every early return and a panic inside the
/// caller's closure clean up after themselves.
struct TempGuard {
    path: PathBuf,
    renamed: bool,
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        if self.renamed {
            return;
        }
        // Ignored: we are already reporting the error that got us here, and a failed cleanup
        // only leaves a hidden temporary file behind.
        let _ = fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            fs::read_dir(dir).expect("read test dir").map(|e| e.expect("dir entry").file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    #[test]
    fn writes_content_and_leaves_no_temp_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("report.json");
        write_atomically(&target, |w| w.write_all(b"{\"a\":1}")).expect("write");
        assert_eq!(fs::read(&target).expect("read back"), b"{\"a\":1}");
        assert_eq!(entries(dir.path()), vec!["report.json"]);

        // Replacing an existing file works the same way.
        write_atomically(&target, |w| w.write_all(b"new")).expect("rewrite");
        assert_eq!(fs::read(&target).expect("read back"), b"new");
        assert_eq!(entries(dir.path()), vec!["report.json"]);
    }

    #[test]
    fn failing_closure_keeps_old_target_and_removes_temp() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("out.png");
        fs::write(&target, b"old content").expect("seed target");
        let err = write_atomically(&target, |w| {
            // Some bytes reach the temporary file before the failure.
            w.write_all(b"partial")?;
            w.flush()?;
            Err(io::Error::other("encoder exploded"))
        })
        .unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("out.png") && msg.contains("encoder exploded"), "{msg}");
        assert_eq!(fs::read(&target).expect("read target"), b"old content");
        assert_eq!(entries(dir.path()), vec!["out.png"]);
    }

    #[test]
    fn failing_closure_does_not_create_target() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("never.exr");
        let result = write_atomically(&target, |_| Err(io::Error::other("nope")));
        assert!(result.is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn panicking_closure_removes_temp() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("panic.exr");
        let outcome = std::panic::catch_unwind(|| {
            let _ = write_atomically(&target, |w| {
                w.write_all(b"x")?;
                panic!("closure panicked");
            });
        });
        assert!(outcome.is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn missing_directory_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("no-such-dir").join("x.json");
        let err = write_atomically(&target, |w| w.write_all(b"x")).unwrap_err();
        assert!(err.to_string().contains("no-such-dir"), "{err}");
    }

    #[test]
    fn path_without_file_name_is_rejected() {
        let err = write_atomically(Path::new(".."), |w| w.write_all(b"x")).unwrap_err();
        assert!(err.to_string().contains(".."), "{err}");
    }
}
