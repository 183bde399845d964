//! The import cache: compressed files and DICOM series become raw NRRD files once, and are
//! memory-mapped from there on every later open.
//!
//! Folder: `--cache-dir`, else `$VOLASSO_CACHE_DIR`, else `$XDG_CACHE_HOME/volasso`, else
//! `$HOME/.cache/volasso`, else `volasso-cache` in the system temporary folder. Entries are
//! named by a SHA-256 of what the import reads (every input file's canonical path, bytes and
//! length, in order: the reader's own listing of its files) and of the import options, so an
//! edited, added or removed source file, or a link pointed elsewhere, gets a new entry. A cache entry that fails to open (truncated by a crash before the rename
//! landed, or by hand) is removed and rebuilt.
//!
//! Never: writes anywhere but its folder, or in place (new entries arrive by rename).

use super::{Volume, VolumeError, limits, nrrd};
use sha2::{Digest, Sha256};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The cache folder to use when none is given.
pub fn default_folder() -> PathBuf {
    if let Some(folder) = std::env::var_os("VOLASSO_CACHE_DIR") {
        return PathBuf::from(folder);
    }
    if let Some(folder) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(folder).join("volasso");
    }
    if let Some(home) = std::env::var_os("HOME") {
        return PathBuf::from(home).join(".cache").join("volasso");
    }
    std::env::temp_dir().join("volasso-cache")
}

/// A content key over `files` and `options` (a description of the import settings that change
/// the result): every file's canonical path (symbolic links resolved), its every byte and its
/// length, in order. Callers list exactly the files their reader opens (the DICOM listing,
/// a header and its detached data file), so a key names exactly what an import read.
pub fn content_key(files: &[PathBuf], options: &str) -> Result<String, VolumeError> {
    let mut hasher = Sha256::new();
    // Version 3: DICOM Modality LUTs and rescales stored as UN are applied; version 2 entries
    // (which carry the patient orientation, `space` fields, unlike version 1) may hold such
    // series' raw values and are not reused.
    hasher.update(b"volasso-cache/3\0");
    hasher.update(options.as_bytes());
    let mut buffer = vec![0u8; 1 << 20];
    for path in files {
        let canonical = std::fs::canonicalize(path).map_err(|e| VolumeError::io(e, path))?;
        let (mut file, _) = limits::open_regular(&canonical)?;
        hasher.update(b"\0file\0");
        hasher.update(canonical.as_os_str().as_encoded_bytes());
        hasher.update(b"\0");
        let mut length = 0u64;
        loop {
            let read = file.read(&mut buffer).map_err(|e| VolumeError::io(e, path))?;
            if read == 0 {
                break;
            }
            length += read as u64;
            hasher.update(&buffer[..read]);
        }
        hasher.update(length.to_le_bytes());
    }
    let digest = hasher.finalize();
    Ok(digest.iter().take(16).map(|b| format!("{b:02x}")).collect())
}

/// Opens the cached volume for the content key of `files` and `settings` (see
/// [`content_key`]), or builds it with `import`, stores it, and opens that. The returned
/// volume is memory-mapped from the cache file, names `source` as its source and carries the
/// import's warnings (e.g. "resampled"), which are also logged and kept beside the entry, so a
/// reused import never hides what was done to it. When the files change while `import` reads
/// them (their key differs afterwards), the import is used but not cached.
pub fn open_or_import(
    folder: &Path,
    files: &[PathBuf],
    settings: &str,
    source: &Path,
    import: impl FnOnce() -> Result<(Volume, Vec<String>), VolumeError>,
) -> Result<Volume, VolumeError> {
    let key = content_key(files, settings)?;
    let entry = folder.join(format!("{key}.nrrd"));
    let warnings_file = folder.join(format!("{key}.warnings"));
    if entry.exists() {
        match nrrd::read(&entry) {
            Ok(read) if !read.decoded => {
                log::info!("{}: using cached import {}", source.display(), entry.display());
                let warnings: Vec<String> =
                    std::fs::read_to_string(&warnings_file).unwrap_or_default().lines().map(str::to_string).collect();
                for warning in &warnings {
                    log::warn!("{}: {warning}", source.display());
                }
                let mut volume = read.volume;
                volume.source = source.to_path_buf();
                volume.warnings = warnings;
                return Ok(volume);
            }
            Ok(_) | Err(_) => {
                log::warn!("cache entry {} is damaged; importing {} again", entry.display(), source.display());
                let _ = std::fs::remove_file(&entry);
            }
        }
    }
    let (mut imported, warnings) = import()?;
    for warning in &warnings {
        log::warn!("{}: {warning}", source.display());
    }
    imported.warnings = warnings.clone();
    if content_key(files, settings).ok().as_deref() != Some(key.as_str()) {
        log::warn!("{} changed while it was imported; using the import without caching it", source.display());
        return Ok(imported);
    }
    let stored = create_folder(folder)
        .and_then(|()| {
            crate::atomic_file::write_atomically(&warnings_file, |file| {
                warnings.iter().try_for_each(|warning| writeln!(file, "{}", warning.replace('\n', " ")))
            })
            .map_err(|source| VolumeError::Write { source, path: warnings_file.clone() })
        })
        .and_then(|()| nrrd::write_volume(&entry, &imported, &format!("volasso import cache of {}", source.display())));
    if let Err(error) = stored {
        // A read-only or full disk costs the next open another import, not this one its volume.
        log::warn!("cannot cache the import of {} ({error}); using it from memory", source.display());
        return Ok(imported);
    }
    log::info!("{}: imported into cache {}", source.display(), entry.display());
    let mut volume = nrrd::read(&entry)?.volume;
    volume.source = source.to_path_buf();
    volume.warnings = warnings;
    Ok(volume)
}

/// Creates the cache folder (and its parents) unless it exists; a file or anything else in
/// its place is [`VolumeError::CacheFolder`], not the operating system's "File exists".
fn create_folder(folder: &Path) -> Result<(), VolumeError> {
    match std::fs::metadata(folder) {
        Ok(metadata) if metadata.is_dir() => return Ok(()),
        Ok(_) => {
            return Err(VolumeError::CacheFolder {
                problem: "it is a file, not a folder".into(),
                path: folder.to_path_buf(),
            });
        }
        Err(_) => {}
    }
    std::fs::create_dir_all(folder).map_err(|error| VolumeError::CacheFolder {
        problem: format!("it cannot be created ({error})"),
        path: folder.to_path_buf(),
    })
}

#[cfg(test)]
mod tests {
    use crate::volume::{OpenOptions, Volume, VoxelType, open};
    use std::path::Path;

    const DICOM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/dicom");

    fn options(cache: &Path) -> OpenOptions {
        OpenOptions { cache_dir: Some(cache.to_path_buf()), ..OpenOptions::default() }
    }

    /// A folder of links to every file of a shared series.
    fn link_series(series: &str, folder: &Path) {
        std::fs::create_dir_all(folder).unwrap();
        for entry in std::fs::read_dir(Path::new(DICOM).join(series)).unwrap() {
            let target = std::fs::canonicalize(entry.unwrap().path()).unwrap();
            std::os::unix::fs::symlink(&target, folder.join(target.file_name().unwrap())).unwrap();
        }
    }

    fn assert_philips(volume: &Volume) {
        assert_eq!((volume.dims, volume.voxel_type), ([512, 512, 28], VoxelType::I16));
    }

    fn assert_ge(volume: &Volume) {
        assert_eq!((volume.dims, volume.voxel_type), ([512, 611, 37], VoxelType::F32));
        assert!(volume.warnings[0].contains("gantry tilt 18.5 deg"), "{:?}", volume.warnings);
    }

    #[test]
    fn folders_of_links_to_two_series_share_a_cache_and_each_opens_its_own() {
        let folder = tempfile::tempdir().unwrap();
        let cache = folder.path().join("cache");
        let (philips, ge) = (folder.path().join("a"), folder.path().join("b"));
        link_series("philips_phantom_5mm", &philips);
        link_series("ge_head_tilt", &ge);
        for _ in 0..2 {
            assert_philips(&open(&philips, &options(&cache)).unwrap());
            assert_ge(&open(&ge, &options(&cache)).unwrap());
        }
        let entries =
            std::fs::read_dir(&cache).unwrap().filter(|e| e.as_ref().unwrap().path().extension().unwrap() == "nrrd");
        assert_eq!(entries.count(), 2);
        // Ten folders deep, behind links, the series still opens (from the cache or not).
        let mut deep = folder.path().join("deep");
        for level in 0..10 {
            deep = deep.join(format!("level{level}"));
        }
        link_series("philips_phantom_5mm", &deep);
        assert_philips(&open(&folder.path().join("deep"), &options(&cache)).unwrap());
        assert_philips(&open(&folder.path().join("deep"), &options(&folder.path().join("cache2"))).unwrap());
    }

    /// A gzip NRRD whose `spacings` leave z unknown (a warning), 2 x 2 x 1 voxels.
    fn gzip_nrrd_with_a_warning(folder: &Path) -> std::path::PathBuf {
        let path = folder.join("v.nrrd");
        let header = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 1\nspacings: 0.5 0.5 NaN\nencoding: gzip\n\n";
        let mut encoder = flate2::write::GzEncoder::new(header.as_bytes().to_vec(), flate2::Compression::fast());
        std::io::Write::write_all(&mut encoder, &[1, 2, 3, 4]).unwrap();
        std::fs::write(&path, encoder.finish().unwrap()).unwrap();
        path
    }

    #[test]
    fn a_reader_warning_survives_the_import_and_every_reuse_of_it() {
        let folder = tempfile::tempdir().unwrap();
        let path = gzip_nrrd_with_a_warning(folder.path());
        for _ in 0..2 {
            let volume = open(&path, &options(&folder.path().join("cache"))).unwrap();
            assert!(volume.is_memory_mapped(), "from the cache");
            assert_eq!(volume.warnings.len(), 1, "{:?}", volume.warnings);
            assert!(volume.warnings[0].contains("no spacing for axis z"), "{:?}", volume.warnings);
        }
    }

    #[test]
    fn a_cache_folder_that_is_a_file_is_named_as_such_and_the_volume_opens_from_memory() {
        let folder = tempfile::tempdir().unwrap();
        let path = gzip_nrrd_with_a_warning(folder.path());
        let file = folder.path().join("cache");
        std::fs::write(&file, b"not a folder").unwrap();
        let volume = open(&path, &options(&file)).unwrap();
        assert!(!volume.is_memory_mapped() && volume.warnings.len() == 1);
        let error = super::create_folder(&file).unwrap_err().to_string();
        assert!(error.contains("cache folder is unusable: it is a file, not a folder"), "{error}");
        let below = super::create_folder(&file.join("below")).unwrap_err().to_string();
        assert!(below.contains("cannot be created"), "{below}");
        assert_eq!(std::fs::read(&file).unwrap(), b"not a folder", "the file is left alone");
    }

    #[test]
    fn a_renamed_dicomdir_keys_its_whole_folder_so_a_changed_series_is_imported_again() {
        let folder = tempfile::tempdir().unwrap();
        let cache = folder.path().join("cache");
        let series = folder.path().join("cd");
        std::fs::create_dir(&series).unwrap();
        let shared = Path::new(DICOM).join("philips_phantom_5mm");
        for name in ["DIRFILE", "I10", "I20", "I30"] {
            std::fs::copy(shared.join(name), series.join(name)).unwrap();
        }
        let dicomdir = series.join("DIRFILE");
        let first = open(&dicomdir, &options(&cache)).unwrap();
        assert_eq!(first.dims, [512, 512, 3]);
        let before = first.value_at(0, 0, 1);
        assert!(before < -900.0, "air in the corner: {before}");
        // Stored sample 0 of I20 becomes 2024, i.e. 1000 HU: the cached import must not hide it.
        let mut bytes = std::fs::read(series.join("I20")).unwrap();
        let pixel_data = bytes.windows(6).rposition(|w| w == [0xE0, 0x7F, 0x10, 0x00, b'O', b'W']).unwrap();
        bytes[pixel_data + 12..pixel_data + 14].copy_from_slice(&2024u16.to_le_bytes());
        std::fs::write(series.join("I20"), &bytes).unwrap();
        let second = open(&dicomdir, &options(&cache)).unwrap();
        assert_eq!(second.value_at(0, 0, 1), 1000.0);
        assert_eq!(first.value_at(0, 0, 1), before, "the first import's cache file is untouched");
        // A removed slice is a changed series too.
        std::fs::remove_file(series.join("I30")).unwrap();
        assert_eq!(open(&dicomdir, &options(&cache)).unwrap().dims, [512, 512, 2]);
    }
}
