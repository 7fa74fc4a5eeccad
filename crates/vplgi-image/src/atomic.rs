//! Atomic file replacement: write a temporary sibling, fsync it, rename it over the target.
//!
//! On Linux the temporary file has no name while it is written (`O_TMPFILE`): a process killed
//! outright (SIGKILL, the OOM killer) leaves nothing in the directory. Once complete it is linked
//! under the target's name if that is free, else under a temporary name renamed over the target
//! at once.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::ImageError;

/// Distinguishes temporary files of concurrent writes from the same process (the pid alone
/// would make two threads writing the same target share, and corrupt, one temporary file).
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: `write` fills a temporary file in the same directory (same
/// directory = same filesystem, so the final rename is atomic): unnamed where the filesystem
/// supports it, else `.<name>.tmp-<pid>-<n>`. It is then flushed, fsynced, given the temporary
/// name if it had none, and renamed over `path`.
///
/// If `write` (or any later step) fails, or panics, the temporary file is removed and `path` is
/// left untouched: it keeps its old content, or stays absent if it did not exist.
/// Errors are reported as [`ImageError::Write`] naming `path`.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> Result<(), ImageError> {
    let wrap = |source: io::Error| ImageError::Write { path: path.to_path_buf(), source };
    let file_name = path.file_name().ok_or_else(|| {
        wrap(io::Error::new(io::ErrorKind::InvalidInput, "the path does not name a file"))
    })?;
    // `Path::parent` of a bare file name is "", which means the current directory.
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(file_name);
    temp_name.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let mut guard = TempGuard { path: dir.join(temp_name), named: false, renamed: false };

    let (file, unnamed) = match open_unnamed(dir) {
        Some(file) => (file, true),
        // Truncate rather than create_new: a leftover with exactly this name can only come
        // from a dead process that had our pid, and it is ours to overwrite.
        None => {
            guard.named = true;
            (
                OpenOptions::new()
                    .write(true)
                    .create(true)
                    .truncate(true)
                    .open(&guard.path)
                    .map_err(wrap)?,
                false,
            )
        }
    };
    let mut writer = BufWriter::new(file);
    write(&mut writer).map_err(wrap)?;
    let file = writer.into_inner().map_err(|e| wrap(e.into_error()))?;
    file.sync_all().map_err(wrap)?;
    if unnamed {
        // Where the target does not exist yet (a fresh output folder), the complete file gets
        // its final name at once and no temporary name ever appears. linkat refuses to replace
        // an existing file, so a rewrite goes through a temporary name and a rename instead.
        match link_unnamed(&file, path) {
            Ok(()) => {
                guard.renamed = true;
                sync_dir(dir);
                return Ok(());
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(wrap(e)),
        }
        link_unnamed(&file, &guard.path).map_err(wrap)?;
        guard.named = true;
    }
    drop(file);
    fs::rename(&guard.path, path).map_err(wrap)?;
    // The rename consumed the temporary file: removing its old name now could only hit an
    // unrelated file created since.
    guard.renamed = true;

    sync_dir(dir);
    Ok(())
}

/// Makes a new name in `dir` durable. Best effort: some platforms cannot open or sync a
/// directory, and the file content is already safely on disk either way.
fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// A file without a name in `dir`, or `None` where the platform or filesystem has no
/// `O_TMPFILE` (the caller then uses a named temporary file).
#[cfg(target_os = "linux")]
fn open_unnamed(dir: &Path) -> Option<File> {
    use std::os::unix::fs::OpenOptionsExt;
    OpenOptions::new().write(true).custom_flags(libc::O_TMPFILE).mode(0o666).open(dir).ok()
}

#[cfg(not(target_os = "linux"))]
fn open_unnamed(_dir: &Path) -> Option<File> {
    None
}

/// Gives the unnamed `file` the name `to` (linkat through /proc/self/fd, as open(2) documents
/// for O_TMPFILE).
#[cfg(target_os = "linux")]
fn link_unnamed(file: &File, to: &Path) -> io::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    use std::os::unix::io::AsRawFd;
    let invalid = |_| io::Error::new(io::ErrorKind::InvalidInput, "a path with a NUL byte");
    let from =
        std::ffi::CString::new(format!("/proc/self/fd/{}", file.as_raw_fd())).map_err(invalid)?;
    let to = std::ffi::CString::new(to.as_os_str().as_bytes()).map_err(invalid)?;
    // SAFETY: both arguments are NUL-terminated strings that outlive the call.
    let r = unsafe {
        libc::linkat(
            libc::AT_FDCWD,
            from.as_ptr(),
            libc::AT_FDCWD,
            to.as_ptr(),
            libc::AT_SYMLINK_FOLLOW,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

#[cfg(not(target_os = "linux"))]
fn link_unnamed(_file: &File, _to: &Path) -> io::Result<()> {
    unreachable!("no unnamed files off Linux")
}

/// Removes the temporary file when dropped, so that every early return and a panic inside the
/// caller's closure clean up after themselves.
struct TempGuard {
    path: PathBuf,
    /// Whether `path` exists (an unnamed file gets its name only when complete).
    named: bool,
    renamed: bool,
}

impl Drop for TempGuard {
    fn drop(&mut self) {
        if self.renamed || !self.named {
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
        let mut names: Vec<String> = fs::read_dir(dir)
            .expect("read test dir")
            .map(|e| e.expect("dir entry").file_name().to_string_lossy().into_owned())
            .collect();
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
    #[cfg(target_os = "linux")]
    fn the_file_has_no_name_while_it_is_written() {
        // A process killed here leaves nothing: there is nothing to see in the directory.
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("unnamed.exr");
        write_atomically(&target, |w| {
            w.write_all(b"partial")?;
            assert!(
                entries(dir.path()).is_empty(),
                "a named file appeared while writing: {:?}",
                entries(dir.path())
            );
            w.write_all(b" and complete")
        })
        .expect("write");
        assert_eq!(fs::read(&target).expect("read"), b"partial and complete");
        assert_eq!(entries(dir.path()), ["unnamed.exr"]);
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
