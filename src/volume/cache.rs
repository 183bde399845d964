//! The import cache: compressed files and DICOM series become raw NRRD files once, and are
//! memory-mapped from there on every later open.
//!
//! Folder: `--cache-dir`, else `$VOLASSO_CACHE_DIR`, else `$XDG_CACHE_HOME/volasso`, else
//! `$HOME/.cache/volasso`, else `volasso-cache` in the system temporary folder. Entries are
//! named by a SHA-256 of the source's content (every byte of every input file, in order) and of
//! the import options, so an edited source gets a new entry and an unchanged one is reused
//! whatever its path. A cache entry that fails to open (truncated by a crash before the rename
//! landed, or by hand) is removed and rebuilt.
//!
//! Never: writes anywhere but its folder, or in place (new entries arrive by rename).

use super::{Volume, VolumeError, nrrd};
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

/// A content key over `files` (all bytes, in order) and `options` (a description of the import
/// settings that change the result).
pub fn content_key(files: &[PathBuf], options: &str) -> Result<String, VolumeError> {
    let mut hasher = Sha256::new();
    // Version 2: entries carry the patient orientation (`space` fields); version 1 entries,
    // written without it, are not reused.
    hasher.update(b"volasso-cache/2\0");
    hasher.update(options.as_bytes());
    let mut buffer = vec![0u8; 1 << 20];
    for path in files {
        let mut file = std::fs::File::open(path).map_err(|e| VolumeError::io(e, path))?;
        hasher.update(b"\0file\0");
        loop {
            let read = file.read(&mut buffer).map_err(|e| VolumeError::io(e, path))?;
            if read == 0 {
                break;
            }
            hasher.update(&buffer[..read]);
        }
    }
    let digest = hasher.finalize();
    Ok(digest.iter().take(16).map(|b| format!("{b:02x}")).collect())
}

/// Opens the cached volume for `key`, or builds it with `import`, stores it, and opens that.
/// The returned volume is memory-mapped from the cache file and names `source` as its source.
/// The import's warnings (e.g. "resampled") are logged, kept beside the entry, and logged
/// again on every later open, so a reused import never hides what was done to it.
pub fn open_or_import(
    folder: &Path,
    key: &str,
    source: &Path,
    import: impl FnOnce() -> Result<(Volume, Vec<String>), VolumeError>,
) -> Result<Volume, VolumeError> {
    let entry = folder.join(format!("{key}.nrrd"));
    let warnings_file = folder.join(format!("{key}.warnings"));
    if entry.exists() {
        match nrrd::read(&entry) {
            Ok(read) if !read.decoded => {
                log::info!("{}: using cached import {}", source.display(), entry.display());
                for warning in std::fs::read_to_string(&warnings_file).unwrap_or_default().lines() {
                    log::warn!("{}: {warning}", source.display());
                }
                let mut volume = read.volume;
                volume.source = source.to_path_buf();
                return Ok(volume);
            }
            Ok(_) | Err(_) => {
                log::warn!("cache entry {} is damaged; importing {} again", entry.display(), source.display());
                let _ = std::fs::remove_file(&entry);
            }
        }
    }
    let (imported, warnings) = import()?;
    for warning in &warnings {
        log::warn!("{}: {warning}", source.display());
    }
    let stored = std::fs::create_dir_all(folder)
        .map_err(|e| VolumeError::io(e, folder))
        .and_then(|()| {
            crate::atomic_file::write_atomically(&warnings_file, |file| {
                warnings.iter().try_for_each(|warning| writeln!(file, "{}", warning.replace('\n', " ")))
            })
            .map_err(|e| VolumeError::io(e, &warnings_file))
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
    Ok(volume)
}
