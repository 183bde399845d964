//! Atomic file writes: a temporary file beside the target, flushed to disk, then renamed over
//! it. A crash or a full disk leaves either the old file or the whole new one, never half.
//!
//! Several outputs that belong together are written as one unit: each is first [`stage`]d
//! (written whole to its temporary file), and only when all are staged are they renamed, in the
//! order the caller gives ([`commit_in_order`]): the file readers look at first goes last, so a
//! reader that sees it new can trust the others beside it are new too.
//!
//! Temporary files are named `.NAME.PID-N.tmp` (NAME the target's file name, PID the writing
//! process). A process killed while writing leaves its temporary behind;
//! [`remove_stale_temporaries`] removes those of processes that are no longer alive.
//!
//! Never: writes in place, or removes a temporary file whose process may still be running.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A file written whole to its temporary sibling and not yet renamed over its target. Dropped
/// without [`commit`](Staged::commit), the temporary file is removed.
#[derive(Debug)]
pub struct Staged {
    /// `None` once renamed.
    temporary: Option<PathBuf>,
    path: PathBuf,
}

impl Staged {
    /// The target the commit renames onto.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Renames the temporary file over the target.
    pub fn commit(mut self) -> std::io::Result<()> {
        let Some(temporary) = self.temporary.take() else { return Ok(()) };
        if let Err(error) = std::fs::rename(&temporary, &self.path) {
            let _ = std::fs::remove_file(&temporary);
            return Err(error);
        }
        sync_folder(&folder_of(&self.path));
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Some(temporary) = self.temporary.take() {
            let _ = std::fs::remove_file(temporary);
        }
    }
}

/// Writes what `fill` writes to a temporary file beside `path` and flushes it to disk; nothing
/// is at `path` until the returned [`Staged`] is committed.
pub fn stage(path: &Path, fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>) -> std::io::Result<Staged> {
    let file_name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path names no file"))?;
    // Process id and a counter keep concurrent writers (two processes, two threads) apart.
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let unique = COUNTER.fetch_add(1, Ordering::Relaxed);
    let temporary =
        folder_of(path).join(format!(".{}.{}-{unique}.tmp", file_name.to_string_lossy(), std::process::id()));
    // From here on, dropping `staged` (an error below) removes the temporary file.
    let staged = Staged { temporary: Some(temporary.clone()), path: path.to_path_buf() };
    let file = File::create(&temporary)?;
    let mut writer = BufWriter::new(file);
    fill(&mut writer)?;
    let file = writer.into_inner().map_err(|e| e.into_error())?;
    count_sync();
    file.sync_all()?;
    Ok(staged)
}

/// Creates `path` through a temporary file in the same folder and a rename.
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    stage(path, fill)?.commit()
}

/// Renames every staged file over its target, first to last. On an error the files not yet
/// renamed keep their old contents (their temporaries are removed) and the error names the
/// target that failed.
pub fn commit_in_order(staged: Vec<Staged>) -> Result<(), (std::io::Error, PathBuf)> {
    for file in staged {
        let path = file.path().to_path_buf();
        file.commit().map_err(|error| (error, path))?;
    }
    Ok(())
}

/// Removes the temporary files of `path` (`.NAME.PID-N.tmp` beside it) left by processes that
/// are no longer running, and returns them. Temporaries of live processes, of other users, or
/// everything where liveness cannot be told (no `/proc`) are left alone.
pub fn remove_stale_temporaries(path: &Path) -> Vec<PathBuf> {
    let Some(target) = path.file_name().map(|name| name.to_string_lossy().into_owned()) else { return Vec::new() };
    let Some(own_uid) = process_owner() else { return Vec::new() };
    let Ok(entries) = std::fs::read_dir(folder_of(path)) else { return Vec::new() };
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = temporary_owner(&name.to_string_lossy(), &target) else { continue };
        // A symlink or folder with a temporary's name is not ours to remove.
        let Ok(metadata) = entry.path().symlink_metadata() else { continue };
        if !metadata.is_file() || owner_of(&metadata) != Some(own_uid) || process_alive(pid) {
            continue;
        }
        match std::fs::remove_file(entry.path()) {
            Ok(()) => removed.push(entry.path()),
            Err(error) => log::warn!("cannot remove the stale temporary file {}: {error}", entry.path().display()),
        }
    }
    removed
}

/// The process id in a temporary name of `target` (`.TARGET.PID-N.tmp`), if `name` is one.
fn temporary_owner(name: &str, target: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?.strip_prefix(target)?.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (pid, counter) = rest.split_once('-')?;
    let digits = |text: &str| !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit());
    (digits(pid) && digits(counter)).then(|| pid.parse().ok()).flatten()
}

/// Whether process `pid` runs: its `/proc` entry exists (a process of another user hidden by
/// `hidepid` counts as not running, which is why only our own files are removed).
fn process_alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists()
}

/// This process's effective user (the owner of `/proc/self`); `None` without `/proc`.
fn process_owner() -> Option<u32> {
    owner_of(&std::fs::metadata("/proc/self").ok()?)
}

#[cfg(unix)]
fn owner_of(metadata: &std::fs::Metadata) -> Option<u32> {
    Some(std::os::unix::fs::MetadataExt::uid(metadata))
}

#[cfg(not(unix))]
fn owner_of(_metadata: &std::fs::Metadata) -> Option<u32> {
    None
}

fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Makes a rename in `folder` durable across a power cut; best effort (some file systems
/// cannot sync a folder, and the rename is atomic either way).
fn sync_folder(folder: &Path) {
    count_sync();
    #[cfg(unix)]
    if let Ok(handle) = File::open(folder) {
        let _ = handle.sync_all();
    }
    #[cfg(not(unix))]
    let _ = folder;
}

thread_local! {
    static SYNCS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

fn count_sync() {
    SYNCS.with(|syncs| syncs.set(syncs.get() + 1));
}

/// How many times this thread has flushed a file or folder to disk here: the app checks that
/// its UI thread never does (`volasso replay` reports it as `ui_thread_syncs`).
pub fn syncs_on_this_thread() -> u64 {
    SYNCS.with(std::cell::Cell::get)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn names(folder: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(folder).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("out.bin");
        write_atomically(&path, |w| w.write_all(b"old")).unwrap();
        let failed = write_atomically(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk full"))
        });
        assert!(failed.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(folder.path()).unwrap().count(), 1);
    }

    #[test]
    fn staged_files_appear_only_when_committed_and_a_dropped_one_leaves_nothing() {
        let folder = tempfile::tempdir().unwrap();
        let (first, second) = (folder.path().join("a.json"), folder.path().join("b.nrrd"));
        let staged =
            vec![stage(&first, |w| w.write_all(b"A")).unwrap(), stage(&second, |w| w.write_all(b"B")).unwrap()];
        // Two temporaries, no target yet.
        assert_eq!(names(folder.path()).len(), 2);
        assert!(!first.exists() && !second.exists());
        commit_in_order(staged).unwrap();
        assert_eq!(names(folder.path()), ["a.json", "b.nrrd"]);
        assert_eq!(std::fs::read(&second).unwrap(), b"B");

        let abandoned = stage(&first, |w| w.write_all(b"new")).unwrap();
        drop(abandoned);
        assert_eq!(names(folder.path()), ["a.json", "b.nrrd"]);
        assert_eq!(std::fs::read(&first).unwrap(), b"A");
    }

    #[test]
    fn a_failed_commit_stops_there_and_keeps_the_later_targets_old() {
        let folder = tempfile::tempdir().unwrap();
        let (first, blocked, last) =
            (folder.path().join("1.bin"), folder.path().join("2.bin"), folder.path().join("3.bin"));
        write_atomically(&last, |w| w.write_all(b"old")).unwrap();
        let staged: Vec<Staged> =
            [&first, &blocked, &last].iter().map(|p| stage(p, |w| w.write_all(b"new")).unwrap()).collect();
        // A folder in the way: renaming a file over it fails.
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("keep"), b"").unwrap();
        let (_, failed_at) = commit_in_order(staged).unwrap_err();
        assert_eq!(failed_at, blocked);
        assert_eq!(std::fs::read(&first).unwrap(), b"new");
        assert_eq!(std::fs::read(&last).unwrap(), b"old");
        assert_eq!(names(folder.path()), ["1.bin", "2.bin", "3.bin"]);
    }

    #[test]
    fn stale_temporaries_of_dead_processes_go_and_live_ones_stay() {
        let folder = tempfile::tempdir().unwrap();
        let target = folder.path().join("labels.nrrd");
        // Above the kernel's largest pid (2^22), so never a running process.
        let dead = folder.path().join(".labels.nrrd.4999999-0.tmp");
        let live = folder.path().join(format!(".labels.nrrd.{}-7.tmp", std::process::id()));
        let other_target = folder.path().join(".labels.nrrd.bak.4999999-0.tmp");
        let not_ours = folder.path().join(".labels.nrrd.4999999.tmp");
        for path in [&dead, &live, &other_target, &not_ours] {
            std::fs::write(path, b"x").unwrap();
        }
        std::fs::create_dir(folder.path().join(".labels.nrrd.4999998-0.tmp")).unwrap();
        let removed = remove_stale_temporaries(&target);
        assert_eq!(removed, vec![dead.clone()]);
        assert!(!dead.exists() && live.exists() && other_target.exists() && not_ours.exists());
        assert!(remove_stale_temporaries(&folder.path().join("missing/labels.nrrd")).is_empty());
    }

    #[test]
    fn temporary_names_are_told_exactly() {
        assert_eq!(temporary_owner(".a.nrrd.123-4.tmp", "a.nrrd"), Some(123));
        assert_eq!(temporary_owner(".a.nrrd.123-.tmp", "a.nrrd"), None);
        assert_eq!(temporary_owner(".a.nrrd.x12-4.tmp", "a.nrrd"), None);
        assert_eq!(temporary_owner(".b.nrrd.123-4.tmp", "a.nrrd"), None);
        assert_eq!(temporary_owner("a.nrrd.123-4.tmp", "a.nrrd"), None);
        assert_eq!(temporary_owner(".a.nrrd.99999999999-4.tmp", "a.nrrd"), None, "not a pid");
    }
}
