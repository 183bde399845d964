//! Shared by the file-level fuzz targets: a private folder per process to write each input
//! into, the limits every reader gets (a 64 MiB decoding ceiling, so memory stays bounded),
//! and a read of whatever a reader accepted.

// Each target uses a part of this module.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use volasso::volume::Volume;
use volasso::volume::limits::ReadLimits;

/// What readers may decode while fuzzing.
pub const LIMITS: ReadLimits = ReadLimits { max_decoded_bytes: 64 << 20, allow_external_data: false };

/// This process's folder for inputs (and the import cache of `volume::open`).
pub fn folder() -> Option<PathBuf> {
    let folder = std::env::temp_dir().join(format!("volasso-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&folder).ok()?;
    Some(folder)
}

/// Writes `data` as `name` in this process's folder.
pub fn write_input(name: &str, data: &[u8]) -> Option<PathBuf> {
    let path = folder()?.join(name);
    std::fs::write(&path, data).ok()?;
    Some(path)
}

/// Reads the first and last voxels and the range of an accepted volume: a reader that
/// accepted a volume promised that every voxel is there.
pub fn read_all(volume: &Volume) {
    let count = volume.voxel_count();
    let mut values = vec![0f32; count.min(1 << 16)];
    volume.read_f32(0, &mut values);
    volume.read_f32(count - values.len(), &mut values);
    let _ = volume.value(count - 1);
    let _ = volume.value_range();
    assert!(volume.check_still_mapped().is_ok());
}

/// Removes `path` (and, for a folder, what is in it).
pub fn remove(path: &Path) {
    let _ = if path.is_dir() { std::fs::remove_dir_all(path) } else { std::fs::remove_file(path) };
}
