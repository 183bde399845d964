//! Finding the image files under a path and choosing the one series to read (see the
//! parent module's doc for the rules).
//!
//! Never: reads pixel data or compares slice geometry.

use super::DicomOptions;
use super::header::{self, FileKind, SliceHeader};
use crate::volume::VolumeError;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The folder to scan, or `None` when `path` is a single image file.
pub(super) fn scan_root(path: &Path) -> Result<Option<PathBuf>, VolumeError> {
    let metadata = std::fs::metadata(path).map_err(|error| VolumeError::io(error, path))?;
    if metadata.is_dir() {
        return Ok(Some(path.to_path_buf()));
    }
    if is_dicomdir_name(path) || is_dicomdir_file(path) {
        let folder = match path.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent.to_path_buf(),
            _ => PathBuf::from("."),
        };
        return Ok(Some(folder));
    }
    Ok(None)
}

/// The image files found: readable headers, and images this reader cannot decode.
pub(super) struct FoundImages {
    pub readable: Vec<SliceHeader>,
    /// (SeriesInstanceUID, SeriesDescription, why), one per file.
    pub unsupported: Vec<(String, String, VolumeError)>,
}

/// Headers of every image file under `folder`, read in parallel.
pub(super) fn read_folder_headers(
    folder: &Path,
    source: &Path,
    warnings: &mut Vec<String>,
) -> Result<FoundImages, VolumeError> {
    let mut candidates = Vec::new();
    let mut other_files = 0usize;
    walk_files(folder, &mut |file| {
        if has_dicm_preamble(file) {
            candidates.push(file.to_path_buf());
        } else {
            other_files += 1;
        }
        true
    });
    candidates.sort();
    log::debug!("{}: {} DICOM files, {other_files} other files skipped", folder.display(), candidates.len());
    let results: Vec<Result<FileKind, VolumeError>> =
        candidates.par_iter().map(|file| header::read_header(file)).collect();
    let mut found = FoundImages { readable: Vec::new(), unsupported: Vec::new() };
    let (mut not_images, mut unreadable) = (0usize, 0usize);
    for result in results {
        match result {
            Ok(FileKind::Image(header)) => found.readable.push(*header),
            Ok(FileKind::Unsupported { series_uid, series_description, error }) => {
                found.unsupported.push((series_uid, series_description, error))
            }
            Ok(FileKind::NotImage) => not_images += 1,
            Err(error) => {
                unreadable += 1;
                warnings.push(format!("skipped: {error}"));
            }
        }
    }
    log::debug!("{}: {not_images} DICOM files without an image", folder.display());
    if found.readable.is_empty() && found.unsupported.is_empty() {
        return Err(VolumeError::Dicom {
            problem: format!(
                "no DICOM image series found ({} DICOM files: {not_images} without an image, {unreadable} unreadable{}; {other_files} other files)",
                candidates.len(),
                warnings.first().map(|w| format!(", first {w}")).unwrap_or_default()
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

/// Calls `visit` on every regular file under `folder` (following links to files, not to
/// folders, so that a link loop cannot trap it), in no particular order, until it returns
/// false. Unreadable folders are skipped.
pub(super) fn walk_files(folder: &Path, visit: &mut dyn FnMut(&Path) -> bool) {
    let mut pending = vec![folder.to_path_buf()];
    while let Some(current) = pending.pop() {
        let Ok(entries) = std::fs::read_dir(&current) else {
            log::debug!("cannot list {}: skipped", current.display());
            continue;
        };
        for entry in entries.flatten() {
            let Ok(file_type) = entry.file_type() else {
                continue;
            };
            let entry_path = entry.path();
            if file_type.is_dir() {
                pending.push(entry_path);
            } else if (file_type.is_file() || (file_type.is_symlink() && entry_path.is_file())) && !visit(&entry_path) {
                return;
            }
        }
    }
}

/// The 128-byte preamble is followed by the magic `DICM` in every DICOM Part 10 file.
pub(super) fn has_dicm_preamble(path: &Path) -> bool {
    let mut head = [0u8; 132];
    match std::fs::File::open(path) {
        Ok(mut file) => file.read_exact(&mut head).is_ok() && &head[128..] == b"DICM",
        Err(_) => false,
    }
}

pub(super) fn is_dicomdir_name(path: &Path) -> bool {
    path.file_name().is_some_and(|name| name.eq_ignore_ascii_case("DICOMDIR"))
}

/// A DICOMDIR under another name (the Philips phantom's is called DIRFILE).
fn is_dicomdir_file(path: &Path) -> bool {
    has_dicm_preamble(path)
        && dicom_object::OpenFileOptions::new()
            .read_until(dicom_dictionary_std::tags::PIXEL_DATA)
            .open_file(path)
            .is_ok_and(|object| object.meta().media_storage_sop_class_uid() == header::MEDIA_STORAGE_DIRECTORY_UID)
}
