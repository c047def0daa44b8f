//! File events on the scene and every file it depends on, merged into edits.
//!
//! The folders holding the files are watched, not the files: editors that save by writing a
//! new file and renaming it over the old one, or by deleting and re-creating it (vim, emacs),
//! replace the watched inode, and a watch on the file itself would go silent.
//!
//! A burst of events is one edit once the events have been quiet for the quiet period. An
//! event that completes a save (a file written and closed, or renamed into place) shortens
//! the wait to a quarter of it: the save is whole, and a quarter still merges the saves of
//! a script that writes several files one after another.

use notify::event::{AccessKind, AccessMode, ModifyKind, RenameMode};
use notify::{EventKind, RecommendedWatcher, RecursiveMode, Watcher as _};
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A file's key for matching events: its folder made absolute (symbolic links resolved)
/// and its name.
fn key(path: &Path) -> PathBuf {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    match path.file_name() {
        Some(n) => dir.join(n),
        None => dir,
    }
}

/// True for an event that completes a save: the file written and closed, or renamed into
/// place.
fn completes_a_save(kind: &EventKind) -> bool {
    matches!(
        kind,
        EventKind::Access(AccessKind::Close(AccessMode::Write))
            | EventKind::Modify(ModifyKind::Name(RenameMode::To | RenameMode::Both))
    )
}

/// Watches files; calls `on_edit` with the time of the first event of each burst once the
/// events have been quiet for `quiet` (a quarter of it after an event that completes a
/// save).
pub(crate) struct FileWatch {
    watcher: RecommendedWatcher,
    dirs: HashSet<PathBuf>,
    files: Arc<Mutex<HashSet<PathBuf>>>,
}

impl FileWatch {
    pub fn new(
        quiet: Duration,
        on_edit: impl Fn(Instant) + Send + 'static,
    ) -> Result<Self, String> {
        let files: Arc<Mutex<HashSet<PathBuf>>> = Arc::default();
        let (tx, rx) = channel::<(Instant, bool)>();
        let watched = files.clone();
        let watcher = notify::recommended_watcher(move |res: notify::Result<notify::Event>| {
            let Ok(ev) = res else { return };
            let complete = completes_a_save(&ev.kind);
            if matches!(ev.kind, EventKind::Access(_)) && !complete {
                return;
            }
            let files = watched.lock().unwrap_or_else(|p| p.into_inner());
            if ev.paths.iter().any(|p| files.contains(&key(p))) {
                let _ = tx.send((Instant::now(), complete));
            }
        })
        .map_err(|e| format!("file events: {e}"))?;
        std::thread::Builder::new()
            .name("isokit-view-watch".into())
            .spawn(move || {
                // One burst: the first event's time, then wait until `quiet` passes with no
                // further event (several writes of one save, or saves in quick succession),
                // a quarter of it after the event that completes a save.
                let wait = |complete: bool| if complete { quiet / 4 } else { quiet };
                while let Ok((first, mut complete)) = rx.recv() {
                    loop {
                        match rx.recv_timeout(wait(complete)) {
                            Ok((_, c)) => complete = c,
                            Err(RecvTimeoutError::Timeout) => break,
                            Err(RecvTimeoutError::Disconnected) => return,
                        }
                    }
                    on_edit(first);
                }
            })
            .map_err(|e| format!("file events: {e}"))?;
        Ok(Self {
            watcher,
            dirs: HashSet::new(),
            files,
        })
    }

    /// Watches exactly `paths` from now on (their folders are watched; missing folders are
    /// skipped).
    pub fn set_files(&mut self, paths: &[PathBuf]) {
        let keys: HashSet<PathBuf> = paths.iter().map(|p| key(p)).collect();
        let dirs: HashSet<PathBuf> = keys
            .iter()
            .filter_map(|k| k.parent().map(Path::to_path_buf))
            .filter(|d| d.is_dir())
            .collect();
        for d in self.dirs.difference(&dirs) {
            let _ = self.watcher.unwatch(d);
        }
        for d in dirs.difference(&self.dirs) {
            let _ = self.watcher.watch(d, RecursiveMode::NonRecursive);
        }
        self.dirs = dirs;
        *self.files.lock().unwrap_or_else(|p| p.into_inner()) = keys;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::{Receiver, channel};

    /// A folder of its own holding `a.json`, and a watch of that file with `quiet` that
    /// sends each edit's first event time and the time it fired.
    fn watched(
        tag: &str,
        quiet: Duration,
    ) -> (PathBuf, PathBuf, FileWatch, Receiver<(Instant, Instant)>) {
        let dir = std::env::temp_dir().join(format!("isokit-watch-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("a.json");
        std::fs::write(&f, "1").unwrap();
        let (tx, rx) = channel();
        let mut w = FileWatch::new(quiet, move |t| {
            let _ = tx.send((t, Instant::now()));
        })
        .unwrap();
        w.set_files(std::slice::from_ref(&f));
        (dir, f, w, rx)
    }

    #[test]
    fn a_burst_of_writes_is_one_edit_and_a_recreated_file_is_followed() {
        let (dir, f, _w, rx) = watched("burst", Duration::from_millis(80));
        for i in 0..5 {
            std::fs::write(&f, format!("{i}")).unwrap();
            std::thread::sleep(Duration::from_millis(10));
        }
        rx.recv_timeout(Duration::from_secs(5)).expect("an edit");
        assert!(
            rx.recv_timeout(Duration::from_millis(300)).is_err(),
            "the burst was one edit"
        );
        // Deleted and re-created (how vim saves), then another file in the folder.
        std::fs::remove_file(&f).unwrap();
        std::fs::write(&f, "again").unwrap();
        rx.recv_timeout(Duration::from_secs(5))
            .expect("the re-created file");
        std::fs::write(dir.join("unrelated.txt"), "x").unwrap();
        assert!(rx.recv_timeout(Duration::from_millis(300)).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_completed_save_waits_a_quarter_of_the_quiet_period() {
        let quiet = Duration::from_millis(1200);
        let (dir, f, _w, rx) = watched("quiet", quiet);
        // Renamed into place (how most editors save), then written in place and closed.
        let tmp = dir.join("a.json.tmp");
        std::fs::write(&tmp, "2").unwrap();
        std::fs::rename(&tmp, &f).unwrap();
        let (first, fired) = rx.recv_timeout(Duration::from_secs(5)).expect("an edit");
        assert!(
            fired - first < Duration::from_millis(900),
            "{:?}",
            fired - first
        );
        std::fs::write(&f, "3").unwrap();
        let (first, fired) = rx.recv_timeout(Duration::from_secs(5)).expect("an edit");
        assert!(
            fired - first < Duration::from_millis(900),
            "{:?}",
            fired - first
        );
        // A write not yet closed waits the whole quiet period.
        let mut open = std::fs::OpenOptions::new().append(true).open(&f).unwrap();
        std::io::Write::write_all(&mut open, b"4").unwrap();
        let (first, fired) = rx.recv_timeout(Duration::from_secs(5)).expect("an edit");
        assert!(fired - first >= quiet, "{:?}", fired - first);
        drop(open);
        let _ = rx.recv_timeout(Duration::from_secs(5));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
