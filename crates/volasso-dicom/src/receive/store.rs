//! Where received images go, and how a series becomes a volume in the data folder, durably
//! and crash-safely.
//!
//! Layout (all on the data folder's filesystem, so renames are atomic; the hidden folder is
//! skipped by the chooser, which skips dot-names):
//! * `DATA/.volasso-receive/incoming/ASSOCIATION/N.dcm`: a data set being received, not yet
//!   acknowledged;
//! * `DATA/.volasso-receive/pending/NAME/SOP.dcm`: acknowledged images of a series not yet
//!   published ([`Store::accept`]);
//! * `DATA/.volasso-receive/candidate/NAME`: a publish under way;
//! * `DATA/NAME/SOP.dcm`: a published series, one DICOM folder that `volasso info` opens.
//!
//! NAME is the series' Modality (letters and digits only, else `DICOM`), a dash, and the first
//! 16 hex digits of the SHA-256 of its SeriesInstanceUID; SOP is the same for the file's
//! SOPInstanceUID. No file or folder name comes from DICOM text, and the same series or image
//! sent again gets the same name.
//!
//! An image is acknowledged only once it is durable: its file is written and flushed
//! (`fsync`), renamed into `pending/NAME`, and that folder flushed ([`Store::accept`]).
//!
//! Publishing ([`Store::publish`]) hard-links the published files and then the pending ones
//! (pending wins, by SOPInstanceUID) into a candidate folder, checks the candidate exactly as
//! the kiosk reads it ([`volasso_core::volume::dicom::check_source`]: every slice decodes, no missing
//! slice, one geometry), flushes it, and swaps it with `DATA/NAME` in one rename (an exchange
//! when the series exists, so a reader sees the old series or the new one, never a mix). Only
//! then are the pending links removed. A kill at any point leaves the published series as it
//! was or as it became, and every acknowledged image still in `pending` or published:
//! [`Store::open`] removes incoming files (never acknowledged) and candidates, puts a series
//! set aside by the fallback swap back, and returns the pending series for publishing again.
//! Publishing the same files again gives the same series.
//!
//! For tests of that claim, the environment variable [`KILL_AT_STEP_VARIABLE`] makes the
//! process kill itself (SIGKILL) just before the N-th filesystem step of its publishes.
//!
//! Never: publishes a series that does not import cleanly, removes an acknowledged image
//! before it is published, removes a published series before its replacement is in place,
//! or writes outside the data folder.

use serde::Serialize;
use sha2::{Digest, Sha256};
use std::ffi::OsString;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use volasso_core::volume::VolumeError;
use volasso_core::volume::dicom::{self, DicomOptions};
use volasso_core::volume::limits::ReadLimits;

/// The hidden folder inside the data folder that holds everything not yet published.
pub const STAGING_FOLDER: &str = ".volasso-receive";
const INCOMING_FOLDER: &str = "incoming";
const PENDING_FOLDER: &str = "pending";
const CANDIDATE_FOLDER: &str = "candidate";
/// The suffix of a published series set aside by [`exchange`]'s fallback.
const ASIDE_SUFFIX: &str = ".old";

/// Test hook: `VOLASSO_RECEIVE_KILL_AT_STEP=N` kills the receiver (SIGKILL) just before the
/// N-th filesystem step of its publishes (counted from 1 over the process' life), and logs
/// each step it counts.
pub const KILL_AT_STEP_VARIABLE: &str = "VOLASSO_RECEIVE_KILL_AT_STEP";

/// How many images a published series holds and how many this publish brought.
#[derive(Clone, Copy, Debug)]
pub struct ImageCounts {
    /// Image files in the series.
    pub images: usize,
    /// Images added or replaced by this publish.
    pub received: usize,
}

impl SeriesReport {
    /// The report of the series `name` published at `path`, as `check` read it back.
    pub fn stored(
        name: String,
        path: PathBuf,
        series_uid: String,
        check: dicom::SeriesCheck,
        counts: ImageCounts,
        replaced: bool,
        calling_ae: String,
    ) -> SeriesReport {
        SeriesReport::Stored {
            name,
            path,
            series_uid,
            modality: check.modality,
            description: check.description,
            images: counts.images,
            received: counts.received,
            dims: check.dims,
            replaced,
            calling_ae,
            warnings: check.warnings,
        }
    }
}

/// One image acknowledged: where it lies in its pending series.
#[derive(Clone, Debug)]
pub struct AcceptedImage {
    /// The series' folder name (see the module doc).
    pub name: String,
    /// The image's file name inside it.
    pub file_name: OsString,
    /// The image's path.
    pub path: PathBuf,
}

/// What became of a series: one JSON line on stdout.
#[derive(Clone, Debug, Serialize, PartialEq)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum SeriesReport {
    /// The series is a volume in the data folder.
    Stored {
        /// The folder's name inside the data folder.
        name: String,
        /// Where the series was published.
        path: PathBuf,
        /// SeriesInstanceUID of the series.
        series_uid: String,
        /// Modality of the series (`CT`, `MR`...), empty when absent.
        modality: String,
        /// SeriesDescription, empty when absent.
        description: String,
        /// Image files in the stored series (this and earlier publishes).
        images: usize,
        /// Images added or replaced by this publish.
        received: usize,
        /// Voxels of the volume along x, y, z.
        dims: [usize; 3],
        /// True when an earlier version of the series was replaced.
        replaced: bool,
        /// AE title of the last sender of the series (empty after a restart).
        calling_ae: String,
        /// What importing the series tolerated or changed, one sentence each.
        warnings: Vec<String>,
    },
    /// The series is held back, unpublished: it does not import cleanly yet (a missing slice,
    /// say), or the association that sent it was aborted.
    Incomplete {
        /// The folder name the series will be published under.
        name: String,
        /// SeriesInstanceUID of the series.
        series_uid: String,
        /// Image files the series would hold (published and pending).
        images: usize,
        /// Images received and not yet published.
        received: usize,
        /// AE title of the last sender of the series (empty after a restart).
        calling_ae: String,
        /// Why it is held back.
        reason: String,
    },
}

/// What a publish did.
pub enum Published {
    /// Nothing was pending for the series.
    Nothing,
    /// The series was published: its report's facts, and the pending files it took.
    Stored { check: dicom::SeriesCheck, images: usize, received: usize, replaced: bool, taken: Vec<OsString> },
    /// The series does not import cleanly; its pending files stay.
    Held { images: usize, received: usize, reason: String },
}

/// The data folder, and the lock that keeps filing an image and publishing its series apart.
pub struct Store {
    data_dir: PathBuf,
    staging: PathBuf,
    /// Held while an image is filed into `pending` and while a publish links or removes
    /// pending files: a publish never removes a file that arrived after it looked.
    filing: Mutex<()>,
    next_association: AtomicU64,
    limits: ReadLimits,
    kill_at_step: Option<u64>,
    steps: AtomicU64,
}

impl Store {
    /// Opens the data folder after a stop or a kill (see the module doc); returns the store
    /// and the names of the series with pending images.
    pub fn open(data_dir: &Path) -> std::io::Result<(Store, Vec<String>)> {
        let staging = data_dir.join(STAGING_FOLDER);
        for folder in [INCOMING_FOLDER, PENDING_FOLDER, CANDIDATE_FOLDER] {
            std::fs::create_dir_all(staging.join(folder))?;
        }
        // A series the fallback swap set aside goes back where it was, unless its
        // replacement is in place.
        for entry in std::fs::read_dir(staging.join(CANDIDATE_FOLDER))?.flatten() {
            let file_name = entry.file_name().to_string_lossy().into_owned();
            if let Some(name) = file_name.strip_suffix(ASIDE_SUFFIX)
                && !data_dir.join(name).exists()
            {
                std::fs::rename(entry.path(), data_dir.join(name))?;
                sync_folder(data_dir)?;
            }
        }
        for folder in [INCOMING_FOLDER, CANDIDATE_FOLDER] {
            for entry in std::fs::read_dir(staging.join(folder))?.flatten() {
                remove_path(&entry.path());
            }
        }
        // Earlier versions of the receiver kept each association's files in a folder of its
        // own (`association-ID/NAME/SOP.dcm`, beside a half-written `incoming-N.dcm`), and had
        // acknowledged those images: they join the pending series, the rest goes.
        for entry in std::fs::read_dir(&staging)?.flatten() {
            if !entry.file_name().to_string_lossy().starts_with("association-") {
                continue;
            }
            for series in std::fs::read_dir(entry.path())?.flatten() {
                if !series.file_type().is_ok_and(|kind| kind.is_dir()) {
                    continue;
                }
                let pending = staging.join(PENDING_FOLDER).join(series.file_name());
                std::fs::create_dir_all(&pending)?;
                for image in std::fs::read_dir(series.path())?.flatten() {
                    std::fs::rename(image.path(), pending.join(image.file_name()))?;
                }
                sync_folder(&pending)?;
            }
            remove_path(&entry.path());
        }
        let mut pending = Vec::new();
        for entry in std::fs::read_dir(staging.join(PENDING_FOLDER))?.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if let Ok(mut files) = std::fs::read_dir(entry.path()) {
                if files.next().is_some() {
                    pending.push(name);
                } else {
                    remove_path(&entry.path());
                }
            }
        }
        pending.sort();
        let kill_at_step = std::env::var(KILL_AT_STEP_VARIABLE).ok().and_then(|value| value.parse().ok());
        let store = Store {
            data_dir: data_dir.to_path_buf(),
            staging,
            filing: Mutex::new(()),
            next_association: AtomicU64::new(0),
            limits: ReadLimits::default(),
            kill_at_step,
            steps: AtomicU64::new(0),
        };
        Ok((store, pending))
    }

    /// Joins the data folder beside a receiver that may be running on it (`volasso pacs get`):
    /// creates the staging folders when missing and recovers nothing, so no other process's
    /// incoming file or publish is touched. Files are named per process, as in [`Store::open`].
    pub fn join(data_dir: &Path) -> std::io::Result<Store> {
        let staging = data_dir.join(STAGING_FOLDER);
        for folder in [INCOMING_FOLDER, PENDING_FOLDER, CANDIDATE_FOLDER] {
            std::fs::create_dir_all(staging.join(folder))?;
        }
        Ok(Store {
            data_dir: data_dir.to_path_buf(),
            staging,
            filing: Mutex::new(()),
            next_association: AtomicU64::new(0),
            limits: ReadLimits::default(),
            kill_at_step: None,
            steps: AtomicU64::new(0),
        })
    }

    pub fn data_dir(&self) -> &Path {
        &self.data_dir
    }

    /// The files of the pending series `name`.
    pub fn pending_files(&self, name: &str) -> Vec<PathBuf> {
        let mut files: Vec<PathBuf> = std::fs::read_dir(self.pending_folder(name))
            .map(|entries| entries.flatten().map(|entry| entry.path()).collect())
            .unwrap_or_default();
        files.sort();
        files
    }

    fn pending_folder(&self, name: &str) -> PathBuf {
        self.staging.join(PENDING_FOLDER).join(name)
    }

    /// A new, empty folder for one association's incoming files.
    pub fn association_folder(&self) -> std::io::Result<PathBuf> {
        let number = self.next_association.fetch_add(1, Ordering::Relaxed);
        let folder = self.staging.join(INCOMING_FOLDER).join(format!("{}-{number}", std::process::id()));
        std::fs::create_dir(&folder)?;
        Ok(folder)
    }

    /// Files a received, flushed image (`incoming`) under its pending series, durably: once
    /// this returns, the image survives a kill or a power cut.
    pub fn accept(
        &self,
        incoming: &Path,
        modality: &str,
        series_uid: &str,
        sop_instance_uid: &str,
    ) -> std::io::Result<AcceptedImage> {
        let name = series_name(modality, series_uid);
        let folder = self.pending_folder(&name);
        let file_name = OsString::from(format!("{}.dcm", short_hash(sop_instance_uid)));
        let path = folder.join(&file_name);
        let _filing = self.filing.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if !folder.exists() {
            std::fs::create_dir(&folder)?;
            sync_folder(&self.staging.join(PENDING_FOLDER))?;
        }
        std::fs::rename(incoming, &path)?;
        sync_folder(&folder)?;
        Ok(AcceptedImage { name, file_name, path })
    }

    /// One filesystem step of a publish: counted, and the test hook's kill point.
    fn step(&self, what: &str) {
        let Some(kill_at) = self.kill_at_step else { return };
        let step = self.steps.fetch_add(1, Ordering::SeqCst) + 1;
        log::warn!("{KILL_AT_STEP_VARIABLE}: publish step {step}: {what}");
        if step == kill_at {
            // SAFETY: kill with this process' own id and a constant signal.
            unsafe {
                libc::kill(libc::getpid(), libc::SIGKILL);
            }
        }
    }

    /// Publishes the pending images of series `name` (see the module doc).
    pub fn publish(&self, name: &str, series_uid: &str) -> std::io::Result<Published> {
        let published = self.data_dir.join(name);
        let pending = self.pending_folder(name);
        let candidates = self.staging.join(CANDIDATE_FOLDER);
        let candidate = candidates.join(name);
        self.step("clear the candidate");
        remove_path(&candidate);
        std::fs::create_dir(&candidate)?;
        // (file name, inode) of each pending file linked.
        let mut taken: Vec<(OsString, u64)> = Vec::new();
        let mut earlier = 0;
        {
            let _filing = self.filing.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            if let Ok(entries) = std::fs::read_dir(&published) {
                for entry in entries.flatten() {
                    self.step("link a published file");
                    std::fs::hard_link(entry.path(), candidate.join(entry.file_name()))?;
                    earlier += 1;
                }
            }
            if let Ok(entries) = std::fs::read_dir(&pending) {
                for entry in entries.flatten() {
                    let target = candidate.join(entry.file_name());
                    self.step("link a pending file");
                    if target.exists() {
                        std::fs::remove_file(&target)?;
                        earlier -= 1;
                    }
                    std::fs::hard_link(entry.path(), &target)?;
                    taken.push((entry.file_name(), std::fs::metadata(&target)?.ino()));
                }
            }
        }
        if taken.is_empty() {
            remove_path(&candidate);
            return Ok(Published::Nothing);
        }
        let images = earlier + taken.len();
        let check = match check_series(&candidate, series_uid, &self.limits) {
            Ok(check) => check,
            Err(error) => {
                remove_path(&candidate);
                let reason = error.to_string().replace(&candidate.display().to_string(), "the series");
                return Ok(Published::Held { images, received: taken.len(), reason });
            }
        };
        self.step("flush the candidate");
        sync_folder(&candidate)?;
        let replaced = published.exists();
        self.step("swap the candidate in");
        if replaced {
            exchange(&candidate, &published, |what| self.step(what))?;
        } else {
            std::fs::rename(&candidate, &published)?;
        }
        self.step("flush the data folder");
        sync_folder(&self.data_dir)?;
        sync_folder(&candidates)?;
        {
            let _filing = self.filing.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            for (file_name, inode) in &taken {
                let path = pending.join(file_name);
                // A file replaced since it was linked (the same image sent again) stays.
                if std::fs::metadata(&path).is_ok_and(|metadata| metadata.ino() == *inode) {
                    self.step("remove a published pending file");
                    std::fs::remove_file(&path)?;
                }
            }
            if std::fs::read_dir(&pending).is_ok_and(|mut entries| entries.next().is_none()) {
                self.step("remove the empty pending folder");
                std::fs::remove_dir(&pending)?;
            }
        }
        self.step("remove the replaced series");
        remove_path(&candidate);
        let taken = taken.into_iter().map(|(file_name, _)| file_name).collect();
        Ok(Published::Stored { check, images, received: images - earlier, replaced, taken })
    }
}

/// The series in `folder` checked as the kiosk reads it (gaps refused, resampling allowed).
pub(crate) fn check_series(
    folder: &Path,
    series_uid: &str,
    limits: &ReadLimits,
) -> Result<dicom::SeriesCheck, VolumeError> {
    let source = dicom::list_source(folder, limits)?;
    let options = DicomOptions { series_uid: Some(series_uid.to_string()), ..DicomOptions::default() };
    let check = dicom::check_source(folder, &source, &options, limits)?;
    // Every file of the folder belongs to the series (they were sorted into it by UID).
    if check.files.len() != source.files.len() {
        return Err(VolumeError::Dicom {
            problem: format!(
                "{} of its {} files are not slices of one volume",
                source.files.len() - check.files.len(),
                source.files.len()
            ),
            path: folder.to_path_buf(),
        });
    }
    Ok(check)
}

/// `MODALITY-HASH`: see the module doc.
pub fn series_name(modality: &str, series_uid: &str) -> String {
    let modality: String = modality.chars().filter(char::is_ascii_alphanumeric).take(16).collect();
    let modality = if modality.is_empty() { "DICOM".to_string() } else { modality.to_ascii_uppercase() };
    format!("{modality}-{}", short_hash(series_uid))
}

/// The first 16 hex digits of the SHA-256 of `text`.
pub fn short_hash(text: &str) -> String {
    Sha256::digest(text.as_bytes()).iter().take(8).map(|byte| format!("{byte:02x}")).collect()
}

/// Swaps two folders in one step (renameat2 RENAME_EXCHANGE); where the filesystem cannot,
/// the old one is set aside (`NAME.old` beside `new`) first: a moment without the series,
/// never a mix, and [`Store::open`] puts it back should the process die in that moment.
fn exchange(new: &Path, old: &Path, mut step: impl FnMut(&str)) -> std::io::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let c_path = |path: &Path| {
        std::ffi::CString::new(path.as_os_str().as_bytes())
            .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "a path holds a NUL byte"))
    };
    let (new_c, old_c) = (c_path(new)?, c_path(old)?);
    // SAFETY: both arguments are NUL-terminated paths that outlive the call.
    let result = unsafe {
        libc::syscall(
            libc::SYS_renameat2,
            libc::AT_FDCWD,
            new_c.as_ptr(),
            libc::AT_FDCWD,
            old_c.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if result == 0 {
        return Ok(());
    }
    let error = std::io::Error::last_os_error();
    if !matches!(error.raw_os_error(), Some(libc::EINVAL | libc::ENOSYS | libc::EOPNOTSUPP)) {
        return Err(error);
    }
    let mut aside = new.as_os_str().to_owned();
    aside.push(ASIDE_SUFFIX);
    let aside = PathBuf::from(aside);
    remove_path(&aside);
    std::fs::rename(old, &aside)?;
    step("swap: the new series in place of the old");
    std::fs::rename(new, old)?;
    step("swap: the old series where the new one was");
    std::fs::rename(&aside, new)
}

/// Flushes a folder's entries (renames into it, new files) to disk.
pub fn sync_folder(folder: &Path) -> std::io::Result<()> {
    std::fs::File::open(folder)?.sync_all()
}

/// Removes a file or folder tree, quietly (it may not exist).
pub fn remove_path(path: &Path) {
    let result = match std::fs::symlink_metadata(path) {
        Ok(metadata) if metadata.is_dir() => std::fs::remove_dir_all(path),
        Ok(_) => std::fs::remove_file(path),
        Err(_) => return,
    };
    if let Err(error) = result {
        log::warn!("cannot remove {}: {error}", path.display());
    }
}

/// The fraction of the filesystem holding `path` that is in use, as `df` counts it
/// (used / (used + available to unprivileged users)).
pub fn used_fraction(path: &Path) -> std::io::Result<f64> {
    use std::os::unix::ffi::OsStrExt;
    let c_path = std::ffi::CString::new(path.as_os_str().as_bytes())
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "a path holds a NUL byte"))?;
    // SAFETY: statvfs only writes the struct it is given; the path is NUL-terminated.
    let mut stats: libc::statvfs = unsafe { std::mem::zeroed() };
    if unsafe { libc::statvfs(c_path.as_ptr(), &mut stats) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    let used = (stats.f_blocks as f64) - (stats.f_bfree as f64);
    let total = used + stats.f_bavail as f64;
    Ok(if total > 0.0 { used / total } else { 1.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_come_from_a_hash_and_a_cleaned_modality() {
        let name = series_name("CT", "1.2.840.113619.2.1");
        assert_eq!(name.len(), "CT-".len() + 16);
        assert!(name.starts_with("CT-"));
        assert_eq!(series_name("ct", "1.2.840.113619.2.1"), name);
        assert!(series_name("../../etc", "1").starts_with("ETC-"));
        assert!(series_name("", "1").starts_with("DICOM-"));
        assert_ne!(series_name("CT", "1.2"), series_name("CT", "1.3"));
    }

    #[test]
    fn an_exchange_swaps_two_folders() {
        let root = tempfile::tempdir().unwrap();
        let (a, b) = (root.path().join("a"), root.path().join("b"));
        std::fs::create_dir(&a).unwrap();
        std::fs::create_dir(&b).unwrap();
        std::fs::write(a.join("new"), "").unwrap();
        std::fs::write(b.join("old"), "").unwrap();
        exchange(&a, &b, |_| {}).unwrap();
        assert!(b.join("new").exists() && a.join("old").exists());
        let fraction = used_fraction(root.path()).unwrap();
        assert!((0.0..=1.0).contains(&fraction), "{fraction}");
    }

    #[test]
    fn opening_keeps_pending_series_and_puts_a_series_set_aside_back() {
        let data = tempfile::tempdir().unwrap();
        let staging = data.path().join(STAGING_FOLDER);
        for folder in ["incoming/1-0", "pending/CT-1", "pending/CT-empty", "candidate/CT-2", "candidate/CT-3.old"] {
            std::fs::create_dir_all(staging.join(folder)).unwrap();
        }
        std::fs::write(staging.join("incoming/1-0/0.dcm"), "half").unwrap();
        std::fs::write(staging.join("pending/CT-1/a.dcm"), "acknowledged").unwrap();
        std::fs::write(staging.join("candidate/CT-3.old/b.dcm"), "published").unwrap();
        // An earlier version's association folder: its series' images were acknowledged.
        std::fs::create_dir_all(staging.join("association-7-0/CT-1")).unwrap();
        std::fs::write(staging.join("association-7-0/CT-1/c.dcm"), "acknowledged earlier").unwrap();
        std::fs::write(staging.join("association-7-0/incoming-3.dcm"), "half").unwrap();
        let (store, pending) = Store::open(data.path()).unwrap();
        assert_eq!(pending, ["CT-1"]);
        assert_eq!(store.pending_files("CT-1").len(), 2);
        assert!(!staging.join("association-7-0").exists());
        assert!(data.path().join("CT-3/b.dcm").exists(), "the series set aside is back");
        assert!(!staging.join("incoming/1-0").exists() && !staging.join("candidate/CT-2").exists());
        assert!(!staging.join("pending/CT-empty").exists());
    }
}
