//! Data that expires: what the appliance keeps of patients (received and retrieved series, the
//! autosaved session, gallery entries, snapshots, the results written for a PACS) is deleted
//! once older than the retention period (`retention_hours`; 24 h by default in clinical mode).
//! The kiosk sweeps at start and every few minutes ([`SWEEP_INTERVAL`]).
//!
//! A thing's age is its modification time: a series folder's is when it was published (a
//! series sent again is published anew), a gallery entry's folder when it was kept, a file's
//! when it was written. A series is first renamed to a hidden name and then removed, so a
//! sweep cut short never leaves a half series where the chooser looks. The scans in `keep` (the
//! open one, the one opening) are never deleted under the user: they go at the first sweep
//! after they are closed.
//!
//! Never: deletes anything but those kinds, in the data and session folders given; follows a
//! symbolic link out of them; deletes a volume the data folder holds that was not received
//! (a demo scan copied there by hand stays).

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// How often the kiosk sweeps.
pub const SWEEP_INTERVAL: Duration = Duration::from_secs(5 * 60);

/// The folders and files the sweep looks at, relative to the data folder.
const GALLERY: &str = "gallery";
const SNAPSHOTS: &str = "snapshots";
const OUTBOX: &str = ".outbox";
/// In the session folder.
const SESSION_FILE: &str = "session.json";
const SESSION_OUTBOX: &str = "outbox";
/// The prefix a series gets while it is removed.
const REMOVING_PREFIX: &str = ".volasso-expiring-";

/// What was deleted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A series the receiver published (pushed, or retrieved from a PACS).
    Series,
    Session,
    GalleryEntry,
    Snapshot,
    /// A Segmentation or Secondary Capture written to send to a PACS.
    Outgoing,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Series => "series",
            Kind::Session => "session",
            Kind::GalleryEntry => "gallery entry",
            Kind::Snapshot => "snapshot",
            Kind::Outgoing => "outgoing result",
        }
    }
}

/// One thing deleted: what, and its name in its folder (a hash or a time, never patient data).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Expired {
    pub kind: Kind,
    pub name: String,
}

/// Where the sweep looks and what it spares.
#[derive(Clone, Debug)]
pub struct Sweep<'a> {
    pub data_dir: &'a Path,
    pub session_dir: Option<&'a Path>,
    /// Things older than this go.
    pub retention: Duration,
    /// Scans in use (the open one): spared whatever their age.
    pub keep: &'a [PathBuf],
}

impl Sweep<'_> {
    /// Deletes what is older than the retention period at `now`; what went (a thing that could
    /// not be deleted is logged and tried again at the next sweep).
    pub fn run(&self, now: SystemTime) -> Vec<Expired> {
        let mut expired = Vec::new();
        let old = |path: &Path| is_older(path, now, self.retention);
        for folder in entries(self.data_dir) {
            let name = file_name(&folder);
            if is_received_series(&name) && folder.is_dir() && old(&folder) && !self.kept(&folder) {
                if remove_series(self.data_dir, &folder, &name) {
                    expired.push(Expired { kind: Kind::Series, name });
                }
            } else if name.starts_with(REMOVING_PREFIX) {
                // A removal cut short by the last sweep's end.
                let _ = std::fs::remove_dir_all(&folder);
            }
        }
        for entry in entries(&self.data_dir.join(GALLERY)) {
            if old(&entry) && remove(&entry) {
                expired.push(Expired { kind: Kind::GalleryEntry, name: file_name(&entry) });
            }
        }
        for (folder, kind) in
            [(self.data_dir.join(SNAPSHOTS), Kind::Snapshot), (self.data_dir.join(OUTBOX), Kind::Outgoing)]
        {
            for file in entries(&folder) {
                if old(&file) && remove(&file) {
                    expired.push(Expired { kind, name: file_name(&file) });
                }
            }
        }
        if let Some(session_dir) = self.session_dir {
            let session = session_dir.join(SESSION_FILE);
            if old(&session) && remove(&session) {
                expired.push(Expired { kind: Kind::Session, name: SESSION_FILE.into() });
            }
            for file in entries(&session_dir.join(SESSION_OUTBOX)) {
                if old(&file) && remove(&file) {
                    expired.push(Expired { kind: Kind::Outgoing, name: file_name(&file) });
                }
            }
        }
        expired
    }

    /// Whether `path` is a scan in use, or holds one or lies in one.
    fn kept(&self, path: &Path) -> bool {
        self.keep.iter().any(|kept| kept.starts_with(path) || path.starts_with(kept))
    }
}

/// When a sweep deletes the received series at `folder` (its age counted from its modification
/// time, as the sweep counts it) with `retention`; `None` for anything else, which no sweep
/// deletes, or when its time cannot be read.
pub fn series_deleted_after(folder: &Path, retention: Duration) -> Option<SystemTime> {
    let name = folder.file_name()?.to_str()?;
    if !is_received_series(name) {
        return None;
    }
    let modified = std::fs::symlink_metadata(folder).ok()?.modified().ok()?;
    Some(modified + retention)
}

/// Whether `name` is one the receiver gives a series folder: its modality (letters and
/// digits), a dash and 16 lower-case hex digits.
pub fn is_received_series(name: &str) -> bool {
    let Some((modality, hash)) = name.rsplit_once('-') else { return false };
    !modality.is_empty()
        && modality.bytes().all(|byte| byte.is_ascii_alphanumeric())
        && hash.len() == 16
        && hash.bytes().all(|byte| matches!(byte, b'0'..=b'9' | b'a'..=b'f'))
}

/// Whether `path` (not followed if a link) was last modified more than `retention` before
/// `now`; false when it is not there or its time cannot be read.
fn is_older(path: &Path, now: SystemTime, retention: Duration) -> bool {
    let Ok(meta) = std::fs::symlink_metadata(path) else { return false };
    let Ok(modified) = meta.modified() else { return false };
    now.duration_since(modified).is_ok_and(|age| age > retention)
}

/// The entries of `folder` (none when it cannot be read), sorted.
fn entries(folder: &Path) -> Vec<PathBuf> {
    let Ok(read) = std::fs::read_dir(folder) else { return Vec::new() };
    let mut paths: Vec<PathBuf> = read.filter_map(|entry| entry.ok().map(|entry| entry.path())).collect();
    paths.sort();
    paths
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or(String::new(), |name| name.to_string_lossy().into_owned())
}

/// A series folder: renamed out of the chooser's sight in one step, then removed.
fn remove_series(data_dir: &Path, folder: &Path, name: &str) -> bool {
    let hidden = data_dir.join(format!("{REMOVING_PREFIX}{name}"));
    if let Err(error) = std::fs::rename(folder, &hidden) {
        log::warn!("cannot remove the expired series {}: {error}", folder.display());
        return false;
    }
    remove(&hidden)
}

/// A file, a link or a folder with what it holds (a link is removed, not followed).
fn remove(path: &Path) -> bool {
    let is_folder = std::fs::symlink_metadata(path).is_ok_and(|meta| meta.is_dir());
    let removed = if is_folder { std::fs::remove_dir_all(path) } else { std::fs::remove_file(path) };
    match removed {
        Ok(()) => true,
        Err(error) => {
            log::warn!("cannot remove the expired {}: {error}", path.display());
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOUR: Duration = Duration::from_secs(3600);

    /// Sets the modification time of `path` to `age` before `now`.
    fn age(path: &Path, now: SystemTime, age: Duration) {
        let file = std::fs::File::open(path).unwrap();
        file.set_modified(now - age).unwrap();
    }

    fn write(path: &Path) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, b"data").unwrap();
    }

    #[test]
    fn what_is_older_than_the_retention_goes_and_the_newer_and_the_open_scan_stay() {
        let data = tempfile::tempdir().unwrap();
        let session = tempfile::tempdir().unwrap();
        let (d, s) = (data.path(), session.path());
        let now = SystemTime::now() + 100 * HOUR;
        let old_series = d.join("CT-0123456789abcdef");
        let new_series = d.join("MR-fedcba9876543210");
        let open_series = d.join("CT-00112233aabbccdd");
        for series in [&old_series, &new_series, &open_series] {
            write(&series.join("0000000000000001.dcm"));
        }
        let demo = d.join("engine_256x256x256_uint8.raw");
        write(&demo);
        let old_entry = d.join(GALLERY).join("result-1700000000");
        let new_entry = d.join(GALLERY).join("result-1700000500");
        write(&old_entry.join("entry.json"));
        write(&new_entry.join("entry.json"));
        let old_snapshot = d.join(SNAPSHOTS).join("volasso-20261205-101010.png");
        let new_snapshot = d.join(SNAPSHOTS).join("volasso-20261206-101010.png");
        write(&old_snapshot);
        write(&new_snapshot);
        let outgoing = d.join(OUTBOX).join("seg-1.dcm");
        write(&outgoing);
        let saved = s.join(SESSION_FILE);
        write(&saved);
        for (path, hours) in [
            (&old_series, 30),
            (&new_series, 2),
            (&open_series, 30),
            (&demo, 500),
            (&old_entry, 25),
            (&new_entry, 23),
            (&old_snapshot, 48),
            (&new_snapshot, 1),
            (&outgoing, 30),
            (&saved, 30),
        ] {
            age(path, now, HOUR * hours);
        }
        let keep = [open_series.clone()];
        let sweep = Sweep { data_dir: d, session_dir: Some(s), retention: 24 * HOUR, keep: &keep };
        let mut gone: Vec<(Kind, String)> = sweep.run(now).into_iter().map(|e| (e.kind, e.name)).collect();
        gone.sort_by_key(|(kind, name)| (kind.name(), name.clone()));
        assert_eq!(
            gone,
            [
                (Kind::GalleryEntry, "result-1700000000".to_string()),
                (Kind::Outgoing, "seg-1.dcm".to_string()),
                (Kind::Series, "CT-0123456789abcdef".to_string()),
                (Kind::Session, SESSION_FILE.to_string()),
                (Kind::Snapshot, "volasso-20261205-101010.png".to_string()),
            ]
        );
        for stays in [&new_series, &open_series, &demo, &new_entry, &new_snapshot] {
            assert!(stays.exists(), "{} stays", stays.display());
        }
        for goes in [&old_series, &old_entry, &old_snapshot, &outgoing, &saved] {
            assert!(!goes.exists(), "{} goes", goes.display());
        }
        assert!(entries(d).iter().all(|path| !file_name(path).starts_with(REMOVING_PREFIX)));
        // Closed, the open scan goes at the next sweep; nothing is deleted twice.
        let next = Sweep { keep: &[], ..sweep };
        let gone: Vec<String> = next.run(now).into_iter().map(|e| e.name).collect();
        assert_eq!(gone, ["CT-00112233aabbccdd"]);
        assert!(next.run(now).is_empty());
    }

    #[test]
    fn a_removal_cut_short_is_finished_and_a_link_is_removed_not_followed() {
        let data = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        let d = data.path();
        let now = SystemTime::now() + 100 * HOUR;
        write(&d.join(format!("{REMOVING_PREFIX}CT-0123456789abcdef")).join("1.dcm"));
        let precious = outside.path().join("precious.png");
        write(&precious);
        std::fs::create_dir_all(d.join(SNAPSHOTS)).unwrap();
        let link = d.join(SNAPSHOTS).join("link.png");
        std::os::unix::fs::symlink(&precious, &link).unwrap();
        let sweep = Sweep { data_dir: d, session_dir: None, retention: HOUR, keep: &[] };
        let gone = sweep.run(now);
        assert_eq!(gone, [Expired { kind: Kind::Snapshot, name: "link.png".into() }]);
        assert!(precious.exists(), "the link's target outside the data folder stays");
        assert!(entries(d).iter().all(|path| !file_name(path).starts_with(REMOVING_PREFIX)));
    }

    #[test]
    fn only_the_receiver_s_names_are_series() {
        for name in ["CT-0123456789abcdef", "MR-fedcba9876543210", "DICOM-0000000000000000"] {
            assert!(is_received_series(name), "{name}");
        }
        for name in ["CT-0123456789ABCDEF", "CT-0123", "engine", "-0123456789abcdef", "C.T-0123456789abcdef", "gallery"]
        {
            assert!(!is_received_series(name), "{name}");
        }
    }
}
