//! Finding the image files under a path and choosing the one series to read (see the
//! parent module's doc for the rules).
//!
//! [`list_source`] is the one listing of the files a DICOM path stands for: the reader reads
//! exactly these and the import cache keys exactly these. It follows symbolic links (to files
//! and to folders, each resolved to its canonical path and listed once, a folder visited once,
//! so a loop of links ends), goes [`MOST_FOLDER_DEPTH`] folders deep, and reports what it could
//! not list (an unreadable folder, a link to nothing, a folder too deep), since a slice of the
//! series may be there.
//!
//! Never: reads pixel data or compares slice geometry.

use super::DicomOptions;
use super::header::{self, FileKind, SliceHeader};
use crate::volume::VolumeError;
use crate::volume::limits::ReadLimits;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::io::Read;
use std::path::{Path, PathBuf};

/// How many folders deep a DICOM folder is searched (a CD's DICOM/ST000/SE000/IM000 is 3).
pub const MOST_FOLDER_DEPTH: usize = 32;

/// The files a DICOM path stands for (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DicomSource {
    /// The folder searched: the path itself, or the folder of a DICOMDIR under any name;
    /// `None` when the path is one image file.
    pub folder: Option<PathBuf>,
    /// Every regular file found, as canonical paths, each once, sorted; or the one file.
    pub files: Vec<PathBuf>,
    /// What could not be searched, one description each.
    pub unlisted: Vec<String>,
}

/// Lists the files `path` (a folder, a DICOMDIR, or one file) stands for.
pub fn list_source(path: &Path, limits: &ReadLimits) -> Result<DicomSource, VolumeError> {
    let Some(folder) = scan_root(path, limits)? else {
        let (_, _) = crate::volume::limits::open_regular(path)?;
        let file = std::fs::canonicalize(path).map_err(|error| VolumeError::io(error, path))?;
        return Ok(DicomSource { folder: None, files: vec![file], unlisted: Vec::new() });
    };
    std::fs::read_dir(&folder).map_err(|error| VolumeError::io(error, &folder))?;
    let mut files = BTreeSet::new();
    let unlisted = walk_files(&folder, &mut |file| {
        files.insert(file.to_path_buf());
        true
    });
    Ok(DicomSource { folder: Some(folder), files: files.into_iter().collect(), unlisted })
}

/// The folder to scan, or `None` when `path` is a single image file.
pub(super) fn scan_root(path: &Path, limits: &ReadLimits) -> Result<Option<PathBuf>, VolumeError> {
    let metadata = std::fs::metadata(path).map_err(|error| VolumeError::io(error, path))?;
    if metadata.is_dir() {
        return Ok(Some(path.to_path_buf()));
    }
    if !metadata.is_file() {
        return Err(VolumeError::NotRegularFile { path: path.to_path_buf() });
    }
    if is_dicomdir_name(path) || is_dicomdir_file(path, limits) {
        let folder = match path.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent.to_path_buf(),
            _ => PathBuf::from("."),
        };
        return Ok(Some(folder));
    }
    Ok(None)
}

/// The image files found: readable headers, images this reader cannot decode, and DICOM files
/// that cannot be read at all (which series they belong to is unknowable).
pub(super) struct FoundImages {
    pub readable: Vec<SliceHeader>,
    /// (SeriesInstanceUID, SeriesDescription, why), one per file.
    pub unsupported: Vec<(String, String, VolumeError)>,
    pub unreadable: Vec<VolumeError>,
}

/// Headers of every DICOM file among `files` (a folder's listing), read in parallel.
pub(super) fn read_folder_headers(
    files: &[PathBuf],
    folder: &Path,
    source: &Path,
    limits: &ReadLimits,
) -> Result<FoundImages, VolumeError> {
    let (candidates, others): (Vec<&PathBuf>, Vec<&PathBuf>) = files.iter().partition(|file| has_dicm_preamble(file));
    log::debug!("{}: {} DICOM files, {} other files skipped", folder.display(), candidates.len(), others.len());
    let results: Vec<Result<FileKind, VolumeError>> =
        candidates.par_iter().map(|file| header::read_header(file, limits)).collect();
    let mut found = FoundImages { readable: Vec::new(), unsupported: Vec::new(), unreadable: Vec::new() };
    let mut not_images = 0usize;
    for result in results {
        match result {
            Ok(FileKind::Image(headers)) => found.readable.extend(headers),
            Ok(FileKind::Unsupported { series_uid, series_description, error }) => {
                found.unsupported.push((series_uid, series_description, error))
            }
            Ok(FileKind::NotImage) => not_images += 1,
            Err(error) => found.unreadable.push(error),
        }
    }
    log::debug!("{}: {not_images} DICOM files without an image", folder.display());
    if found.readable.is_empty() && found.unsupported.is_empty() {
        return Err(VolumeError::Dicom {
            problem: format!(
                "no DICOM image series found ({} DICOM files: {not_images} without an image, {} unreadable{}; {} other files)",
                candidates.len(),
                found.unreadable.len(),
                found.unreadable.first().map(|error| format!(", first: {error}")).unwrap_or_default(),
                others.len()
            ),
            path: source.to_path_buf(),
        });
    }
    Ok(found)
}

/// Groups the images by SeriesInstanceUID and returns the one series to read: the one asked
/// for, or the only readable one (other series that cannot be read are skipped with a
/// warning). Several readable series and no choice is an error listing them.
pub(super) fn choose_series(
    found: FoundImages,
    options: &DicomOptions,
    source: &Path,
    warnings: &mut Vec<String>,
) -> Result<(String, Vec<SliceHeader>), VolumeError> {
    let mut readable: BTreeMap<String, Vec<SliceHeader>> = BTreeMap::new();
    for header in found.readable {
        readable.entry(header.series_uid.clone()).or_default().push(header);
    }
    // A series with any unsupported file cannot be read as a whole.
    let mut unsupported: BTreeMap<String, (String, usize, VolumeError)> = BTreeMap::new();
    for (uid, description, error) in found.unsupported {
        unsupported.entry(uid).and_modify(|(_, count, _)| *count += 1).or_insert((description, 1, error));
    }
    for (uid, (_, count, _)) in unsupported.iter_mut() {
        *count += readable.remove(uid).map_or(0, |slices| slices.len());
    }
    let name = |uid: &str| {
        if uid.is_empty() { "(no SeriesInstanceUID)".to_string() } else { uid.to_string() }
    };
    let listing = |readable: &BTreeMap<String, Vec<SliceHeader>>,
                   unsupported: &BTreeMap<String, (String, usize, VolumeError)>| {
        let readable = readable.iter().map(|(uid, slices)| {
            format!("{} \"{}\" ({} slices)", name(uid), slices[0].series_description, slices.len())
        });
        let unreadable = unsupported.iter().map(|(uid, (description, count, _))| {
            format!("{} \"{description}\" ({count} files, not readable)", name(uid))
        });
        readable.chain(unreadable).collect::<Vec<_>>().join("; ")
    };
    if let Some(wanted) = &options.series_uid {
        if let Some((_, _, error)) = unsupported.remove(wanted) {
            return Err(error);
        }
        return match readable.remove(wanted) {
            Some(slices) => Ok((wanted.clone(), slices)),
            None => Err(VolumeError::Dicom {
                problem: format!(
                    "series {wanted} is not here; the image series are: {}",
                    listing(&readable, &unsupported)
                ),
                path: source.to_path_buf(),
            }),
        };
    }
    if readable.len() > 1 {
        return Err(VolumeError::Dicom {
            problem: format!(
                "{} image series found, choose one with --series UID: {}",
                readable.len(),
                listing(&readable, &unsupported)
            ),
            path: source.to_path_buf(),
        });
    }
    match readable.pop_first() {
        Some((uid, slices)) => {
            for (other, (description, count, error)) in &unsupported {
                warnings.push(format!("skipped series {} \"{description}\" ({count} files): {error}", name(other)));
            }
            Ok((uid, slices))
        }
        None => match unsupported.pop_first() {
            Some((_, (_, _, error))) => Err(error),
            None => {
                Err(VolumeError::Dicom { problem: "no DICOM image series found".into(), path: source.to_path_buf() })
            }
        },
    }
}

/// Calls `visit` with the canonical path of every regular file under `folder` (following
/// links to files and folders; each folder visited once, so a loop of links ends), in no
/// particular order, until it returns false. Returns what could not be searched.
pub(super) fn walk_files(folder: &Path, visit: &mut dyn FnMut(&Path) -> bool) -> Vec<String> {
    let mut unlisted = Vec::new();
    let root = match std::fs::canonicalize(folder) {
        Ok(root) => root,
        Err(error) => {
            unlisted.push(format!("{} ({error})", folder.display()));
            return unlisted;
        }
    };
    let mut visited = HashSet::from([root.clone()]);
    let mut pending = vec![(root, 0usize)];
    while let Some((current, depth)) = pending.pop() {
        let entries = match std::fs::read_dir(&current) {
            Ok(entries) => entries,
            Err(error) => {
                unlisted.push(format!("folder {} ({error})", current.display()));
                continue;
            }
        };
        for entry in entries {
            let entry_path = match entry {
                Ok(entry) => entry.path(),
                Err(error) => {
                    unlisted.push(format!("an entry of {} ({error})", current.display()));
                    continue;
                }
            };
            let resolved = std::fs::metadata(&entry_path).and_then(|m| Ok((m, std::fs::canonicalize(&entry_path)?)));
            let (metadata, canonical) = match resolved {
                Ok(resolved) => resolved,
                Err(error) => {
                    unlisted.push(format!("{} ({error})", entry_path.display()));
                    continue;
                }
            };
            if metadata.is_dir() {
                if !visited.insert(canonical.clone()) {
                    continue;
                }
                if depth + 1 > MOST_FOLDER_DEPTH {
                    unlisted.push(format!("folder {} (deeper than {MOST_FOLDER_DEPTH} folders)", entry_path.display()));
                    continue;
                }
                pending.push((canonical, depth + 1));
            } else if metadata.is_file() && !visit(&canonical) {
                return unlisted;
            }
        }
    }
    unlisted
}

/// The 128-byte preamble is followed by the magic `DICM` in every DICOM Part 10 file.
pub(super) fn has_dicm_preamble(path: &Path) -> bool {
    let mut head = [0u8; 132];
    match crate::volume::limits::open_regular(path) {
        Ok((mut file, _)) => file.read_exact(&mut head).is_ok() && &head[128..] == b"DICM",
        Err(_) => false,
    }
}

pub(super) fn is_dicomdir_name(path: &Path) -> bool {
    path.file_name().is_some_and(|name| name.eq_ignore_ascii_case("DICOMDIR"))
}

/// A DICOMDIR under another name (the Philips phantom's is called DIRFILE).
fn is_dicomdir_file(path: &Path, limits: &ReadLimits) -> bool {
    has_dicm_preamble(path)
        && super::bounds::read_object(path, super::bounds::Scope::Header, limits)
            .is_ok_and(|object| object.meta().media_storage_sop_class_uid() == header::MEDIA_STORAGE_DIRECTORY_UID)
}
