//! Atomic file output: write a temporary file next to the target, flush it to disk, rename.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::IoError;

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes a file atomically: `f` writes into a temporary file in the same directory, which is
/// flushed, synced to disk and renamed over `path`.
///
/// When `f` (or any step) fails, the temporary file is removed and an existing file at
/// `path` is left untouched; readers never see a half-written file. Every writer in this
/// crate goes through this function.
///
/// ```
/// # let dir = std::env::temp_dir().join(format!("isokit-doc-{}", std::process::id()));
/// # std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("hello.txt");
/// isokit_io::atomic_write(&path, |w| w.write_all(b"hello")).unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"hello");
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn atomic_write(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let Some(name) = path.file_name() else {
        return Err(IoError::invalid_input(path, "the path names no file"));
    };
    if path.is_dir() {
        return Err(IoError::invalid_input(path, "the path is a directory"));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // Find a fresh temporary name (create_new never clobbers anything).
    let (tmp, file) = {
        let mut attempt = 0;
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let mut tmp_name = std::ffi::OsString::from(".");
            tmp_name.push(name);
            tmp_name.push(format!(".tmp-{}-{n}", std::process::id()));
            let tmp = dir.join(tmp_name);
            match OpenOptions::new().write(true).create_new(true).open(&tmp) {
                Ok(file) => break (tmp, file),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 100 => {
                    attempt += 1;
                }
                Err(e) => return Err(IoError::io(path, e)),
            }
        }
    };
    let result = write_and_sync(file, f).and_then(|()| std::fs::rename(&tmp, path));
    match result {
        Ok(()) => {
            // Make the rename durable where the platform allows it (best effort).
            #[cfg(unix)]
            if let Ok(d) = File::open(&dir) {
                let _ = d.sync_all();
            }
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(IoError::io(path, e))
        }
    }
}

fn write_and_sync(
    file: File,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut w = BufWriter::with_capacity(1 << 16, file);
    f(&mut w)?;
    let file = w.into_inner().map_err(|e| e.into_error())?;
    file.sync_all()
}

/// Writes bytes already held in memory atomically.
pub(crate) fn atomic_write_bytes(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    atomic_write(path, |w| w.write_all(bytes))
}
