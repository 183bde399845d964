//! Where received images go, and how a series becomes a volume in the data folder.
//!
//! Layout (all on the data folder's filesystem, so renames are atomic):
//! * `DATA/.volasso-receive/ASSOCIATION/NAME/SOP.dcm`: the files of one association as they
//!   arrive (hidden: the chooser skips dot-names);
//! * `DATA/.volasso-receive/pending/NAME/`: a series that did not yet import cleanly, kept for
//!   the association that completes it;
//! * `DATA/NAME/SOP.dcm`: a published series, one DICOM folder that `volasso info` opens.
//!
//! NAME is the series' Modality (letters and digits only, else `DICOM`), a dash, and the first
//! 16 hex digits of the SHA-256 of its SeriesInstanceUID; SOP is the same for the file's
//! SOPInstanceUID. No file or folder name comes from DICOM text, and the same series or image
//! sent again gets the same name.
//!
//! Publishing ([`Store::publish`]) happens when an association is released normally: for each
//! series it received, the published files and pending files of that series and the new ones
//! (new ones win, by SOPInstanceUID) are linked into a candidate folder, and the candidate is
//! checked exactly as the kiosk would read it ([`crate::volume::dicom::check_source`]: every
//! slice decodes, no missing slice, one geometry). A clean series replaces `DATA/NAME` in one
//! rename (an exchange when it exists, so a reader sees the old series or the new one, never a
//! mix); one that is not clean becomes the pending series and is reported as incomplete.
//!
//! Never: publishes part of a series that does not import cleanly, removes a published series
//! before its replacement is in place, or writes outside the data folder.

use crate::volume::VolumeError;
use crate::volume::dicom::{self, DicomOptions};
use crate::volume::limits::ReadLimits;
use serde::Serialize;
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// The hidden folder inside the data folder that holds everything not yet published.
pub const STAGING_FOLDER: &str = ".volasso-receive";
const PENDING_FOLDER: &str = "pending";

/// One image received and written whole.
#[derive(Clone, Debug)]
pub struct ReceivedImage {
    pub series_uid: String,
    pub modality: String,
    pub path: PathBuf,
}

/// What became of one series at the end of an association: one JSON line on stdout.
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
        /// Image files in the stored series (this and earlier associations).
        images: usize,
        /// Images this association sent.
        received: usize,
        /// Voxels of the volume along x, y, z.
        dims: [usize; 3],
        /// True when an earlier version of the series was replaced.
        replaced: bool,
        /// AE title of the sender.
        calling_ae: String,
        /// What importing the series tolerated or changed, one sentence each.
        warnings: Vec<String>,
    },
    /// The series does not import cleanly yet (a missing slice, say): kept aside, unpublished.
    Incomplete {
        /// The folder name the series will be published under.
        name: String,
        /// SeriesInstanceUID of the series.
        series_uid: String,
        /// Image files held for the series so far (this and earlier associations).
        images: usize,
        /// Images this association sent.
        received: usize,
        /// AE title of the sender.
        calling_ae: String,
        /// Why it does not import yet.
        reason: String,
    },
}

/// The data folder and the lock that makes publishing one series at a time.
pub struct Store {
    data_dir: PathBuf,
    staging: PathBuf,
    publishing: Mutex<()>,
    next_association: AtomicU64,
    limits: ReadLimits,
}

impl Store {
    /// Opens the data folder, creating the staging folder and removing what killed receivers
    /// left in it (association folders; pending series are kept).
    pub fn open(data_dir: &Path) -> std::io::Result<Store> {
        let staging = data_dir.join(STAGING_FOLDER);
        std::fs::create_dir_all(staging.join(PENDING_FOLDER))?;
        for entry in std::fs::read_dir(&staging)?.flatten() {
            if entry.file_name() != PENDING_FOLDER {
                remove_path(&entry.path());
            }
        }
        Ok(Store {
            data_dir: data_dir.to_path_buf(),
            staging,
            publishing: Mutex::new(()),
            next_association: AtomicU64::new(0),
            limits: ReadLimits::default(),
        })
    }

    pub fn data_dir(&self) -> &Path {
        &self.data_dir
    }

    /// A new, empty folder for one association's files.
    pub fn association_folder(&self) -> std::io::Result<PathBuf> {
        let number = self.next_association.fetch_add(1, Ordering::Relaxed);
        let folder = self.staging.join(format!("association-{}-{number}", std::process::id()));
        std::fs::create_dir(&folder)?;
        Ok(folder)
    }

    /// Publishes each series of `images` (received in `folder` by one association that ended
    /// normally) and removes `folder`; one report per series.
    pub fn publish(&self, folder: &Path, images: &[ReceivedImage], calling_ae: &str) -> Vec<SeriesReport> {
        let mut by_series: BTreeMap<&str, Vec<&ReceivedImage>> = BTreeMap::new();
        for image in images {
            by_series.entry(image.series_uid.as_str()).or_default().push(image);
        }
        let reports = by_series
            .into_iter()
            .map(|(series_uid, images)| {
                let name = series_name(&images[0].modality, series_uid);
                // One series at a time: two associations may carry the same series.
                let _guard = self.publishing.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                self.publish_series(&name, series_uid, &images, calling_ae).unwrap_or_else(|error| {
                    log::error!("cannot store series {name}: {error}");
                    SeriesReport::Incomplete {
                        name,
                        series_uid: series_uid.to_string(),
                        images: 0,
                        received: images.len(),
                        calling_ae: calling_ae.to_string(),
                        reason: format!("cannot write the series ({error})"),
                    }
                })
            })
            .collect();
        remove_path(folder);
        reports
    }

    fn publish_series(
        &self,
        name: &str,
        series_uid: &str,
        images: &[&ReceivedImage],
        calling_ae: &str,
    ) -> std::io::Result<SeriesReport> {
        let published = self.data_dir.join(name);
        let pending = self.staging.join(PENDING_FOLDER).join(name);
        let candidate = self.staging.join(format!("{name}.candidate"));
        remove_path(&candidate);
        std::fs::create_dir(&candidate)?;
        // Earlier images first, so that the new ones replace them by name (SOPInstanceUID).
        for earlier in [&published, &pending] {
            if let Ok(entries) = std::fs::read_dir(earlier) {
                for entry in entries.flatten() {
                    let target = candidate.join(entry.file_name());
                    if !target.exists() {
                        std::fs::hard_link(entry.path(), target)?;
                    }
                }
            }
        }
        for image in images {
            if let Some(file_name) = image.path.file_name() {
                std::fs::rename(&image.path, candidate.join(file_name))?;
            }
        }
        let count = std::fs::read_dir(&candidate)?.count();
        let incomplete = |reason: String| SeriesReport::Incomplete {
            name: name.to_string(),
            series_uid: series_uid.to_string(),
            images: count,
            received: images.len(),
            calling_ae: calling_ae.to_string(),
            reason,
        };
        let checked = check_series(&candidate, series_uid, &self.limits);
        let check = match checked {
            Ok(check) => check,
            Err(error) => {
                remove_path(&pending);
                std::fs::rename(&candidate, &pending)?;
                log::warn!("series {name} is held back until it imports cleanly: {error}");
                return Ok(incomplete(error.to_string()));
            }
        };
        sync_folder(&candidate);
        let replaced = published.exists();
        if replaced {
            exchange(&candidate, &published)?;
            remove_path(&candidate);
        } else {
            std::fs::rename(&candidate, &published)?;
        }
        sync_folder(&self.data_dir);
        remove_path(&pending);
        Ok(SeriesReport::Stored {
            name: name.to_string(),
            path: published,
            series_uid: series_uid.to_string(),
            modality: check.modality,
            description: check.description,
            images: count,
            received: images.len(),
            dims: check.dims,
            replaced,
            calling_ae: calling_ae.to_string(),
            warnings: check.warnings,
        })
    }
}

/// The series in `folder` checked as the kiosk reads it (gaps refused, resampling allowed).
fn check_series(folder: &Path, series_uid: &str, limits: &ReadLimits) -> Result<dicom::SeriesCheck, VolumeError> {
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
/// the old one is renamed aside first (a moment without the series, never a mix).
fn exchange(new: &Path, old: &Path) -> std::io::Result<()> {
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
    let aside = new.with_extension("old");
    remove_path(&aside);
    std::fs::rename(old, &aside)?;
    std::fs::rename(new, old)?;
    std::fs::rename(&aside, new)
}

/// Flushes a folder's entries (renames into it, new files) to disk; best effort.
fn sync_folder(folder: &Path) {
    if let Ok(handle) = std::fs::File::open(folder) {
        let _ = handle.sync_all();
    }
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
        exchange(&a, &b).unwrap();
        assert!(b.join("new").exists() && a.join("old").exists());
        let fraction = used_fraction(root.path()).unwrap();
        assert!((0.0..=1.0).contains(&fraction), "{fraction}");
    }
}
