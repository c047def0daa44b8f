//! Atomic file output: write a temporary file next to the target, flush it to disk, rename.

use std::ffi::{OsStr, OsString};
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
/// The temporary file is named `.NAME.isokit-PID-N.tmp` ([`temporary_name`]). A process
/// killed while writing (`kill -9`, power loss) cannot remove it; the next write of the same
/// output removes every such file whose writer is gone (no process `PID` runs any more,
/// read from `/proc`; where there is no `/proc`, files older than a day).
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
    remove_orphans(&dir, name);
    // Find a fresh temporary name (create_new never clobbers anything).
    let (tmp, file) = {
        let mut attempt = 0;
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let tmp = dir.join(temporary_name(name, std::process::id(), n));
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

/// The temporary file [`atomic_write`] writes `NAME` through: `.NAME.isokit-PID-N.tmp` (`N`
/// counts the writes of this process).
pub fn temporary_name(name: &OsStr, pid: u32, n: u64) -> OsString {
    let mut tmp = OsString::from(".");
    tmp.push(name);
    tmp.push(format!("{TMP_MARK}{pid}-{n}.tmp"));
    tmp
}

const TMP_MARK: &str = ".isokit-";

/// The writer's process id of a temporary name of `name`, if `file` is one.
fn temporary_pid(file: &OsStr, name: &OsStr) -> Option<u32> {
    let file = file.as_encoded_bytes();
    let rest = file
        .strip_prefix(b".")?
        .strip_prefix(name.as_encoded_bytes())?
        .strip_prefix(TMP_MARK.as_bytes())?
        .strip_suffix(b".tmp")?;
    let (pid, n) = std::str::from_utf8(rest).ok()?.split_once('-')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

/// Whether the process that wrote a temporary file is gone.
fn writer_gone(pid: u32, tmp: &Path) -> bool {
    if pid == std::process::id() {
        return false;
    }
    if Path::new("/proc/self").exists() {
        return !Path::new(&format!("/proc/{pid}")).exists();
    }
    // No process table to read: only files untouched for a day.
    std::fs::metadata(tmp)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age.as_secs() > 24 * 3600)
}

/// Removes the temporary files of `name` in `dir` left by writers that are gone (best
/// effort: failures are ignored, nothing else is touched).
fn remove_orphans(dir: &Path, name: &OsStr) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name();
        if let Some(pid) = temporary_pid(&file, name) {
            let tmp = dir.join(&file);
            if e.file_type().is_ok_and(|t| t.is_file()) && writer_gone(pid, &tmp) {
                let _ = std::fs::remove_file(&tmp);
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_names_are_recognized() {
        let name = OsStr::new("big.nrrd");
        let t = temporary_name(name, 42, 7);
        assert_eq!(t, ".big.nrrd.isokit-42-7.tmp");
        assert_eq!(temporary_pid(&t, name), Some(42));
        assert_eq!(temporary_pid(&t, OsStr::new("big.nrr")), None);
        for other in [
            ".big.nrrd.tmp-42-7",
            "big.nrrd",
            ".big.nrrd.isokit-x-7.tmp",
            ".big.nrrd.isokit-42.tmp",
        ] {
            assert_eq!(temporary_pid(OsStr::new(other), name), None, "{other}");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn orphans_of_gone_writers_are_removed_and_nothing_else() {
        let dir = std::env::temp_dir().join(format!("isokit-orphans-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let name = OsStr::new("out.npy");
        // A pid above the kernel's maximum (4194304) never runs.
        let gone = dir.join(temporary_name(name, 4_194_305, 0));
        let alive = dir.join(temporary_name(name, std::process::id(), 999));
        let other = dir.join(temporary_name(OsStr::new("other.npy"), 4_194_305, 0));
        for p in [&gone, &alive, &other] {
            std::fs::write(p, b"partial").unwrap();
        }
        atomic_write(&dir.join("out.npy"), |w| w.write_all(b"new")).unwrap();
        assert!(!gone.exists());
        assert!(alive.exists() && other.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
