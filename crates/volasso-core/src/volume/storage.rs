//! Where voxel bytes live: a read-only memory map of a file region, or owned bytes.
//!
//! Mapping is the point of the whole volume stage: opening the 16 MiB engine volume must not
//! make it resident. When a map cannot be made (a pipe, a file system without mmap), the
//! region is read instead and a warning says so, as ripgrep's searcher falls back.
//!
//! A mapped file that shrinks while mapped makes every read of the lost pages raise SIGBUS,
//! which no Rust code can turn into an error (memmap2's `Mmap::map` documents the hazard;
//! ripgrep accepts it for the same reason). What this module does about it:
//! [`VoxelBytes::check_still_mapped`] compares the file's current length (an `fstat` of the
//! handle kept open beside the map) with the mapped region and returns
//! [`VolumeError::Shrunk`], and the pipeline calls it (through
//! [`super::Volume::check_still_mapped`]) before each whole-volume pass, so a file truncated
//! between passes gives an error instead of a crash. A truncation *during* a pass is not
//! caught; the appliance rules it out by keeping volumes on a data partition that nothing
//! writes in place (imports arrive by rename, the USB import copies new files).

use super::VolumeError;
use memmap2::Mmap;
use std::fs::File;
use std::path::{Path, PathBuf};

/// The voxel bytes of a volume.
#[derive(Debug)]
pub enum VoxelBytes {
    /// `len` bytes at `offset` of a mapped file; `file` stays open to check its length.
    Mapped {
        /// The whole file, mapped read-only.
        map: Mmap,
        /// Byte offset of the first voxel in the file.
        offset: usize,
        /// Number of voxel bytes.
        len: usize,
        /// The open file behind the map.
        file: File,
        /// The file's path, for errors.
        path: PathBuf,
    },
    /// Bytes in RAM (generated volumes, small or decoded data).
    Owned(Vec<u8>),
}

impl VoxelBytes {
    /// Maps `len` bytes at `offset` of `path`, after checking that the file is a regular file
    /// and holds them. Falls back to reading them when the map fails.
    pub fn map_region(path: &Path, offset: u64, len: usize) -> Result<VoxelBytes, VolumeError> {
        let (file, file_len) = super::limits::open_regular(path)?;
        let available = file_len.saturating_sub(offset);
        if (len as u64) > available {
            return Err(VolumeError::DataSize { expected: len, found: available as usize, path: path.to_path_buf() });
        }
        if len == 0 {
            return Ok(VoxelBytes::Owned(Vec::new()));
        }
        // SAFETY: the map is read-only and private to this process. The file may still be changed
        // by another process while mapped (undefined in Rust's model); the appliance keeps its
        // volumes on a data partition that nothing else writes, and the cache writes new files
        // by rename and never in place. The length check above keeps every read inside the file
        // as it was at open time, and `check_still_mapped` catches a file shrunk since (see the
        // module doc).
        let mapped = unsafe { Mmap::map(&file) };
        match mapped {
            Ok(map) => {
                #[cfg(unix)]
                {
                    // Whole-volume passes read front to back; tell the kernel.
                    let _ = map.advise(memmap2::Advice::Sequential);
                }
                Ok(VoxelBytes::Mapped { map, offset: offset as usize, len, file, path: path.to_path_buf() })
            }
            Err(error) => {
                log::warn!("memory map of {} failed ({error}); reading it into memory instead", path.display());
                read_region(file, path, offset, len)
            }
        }
    }

    /// Maps `len` bytes at `offset` of `path` that must end the file, as a header's voxel data
    /// do: a shorter file is [`VolumeError::DataSize`], bytes after the data
    /// [`VolumeError::TrailingData`] (the header's sizes, type or offset are wrong; decoded
    /// data that runs on is refused the same way, [`super::limits::decode_exactly`]).
    pub fn map_final_region(path: &Path, offset: u64, len: usize) -> Result<VoxelBytes, VolumeError> {
        let (_, file_len) = super::limits::open_regular(path)?;
        let end = offset.saturating_add(len as u64);
        if file_len > end {
            return Err(VolumeError::TrailingData {
                expected: len as u64,
                extra: file_len - end,
                path: path.to_path_buf(),
            });
        }
        VoxelBytes::map_region(path, offset, len)
    }

    /// The voxel bytes, in the file's order and byte order.
    pub fn as_slice(&self) -> &[u8] {
        match self {
            VoxelBytes::Mapped { map, offset, len, .. } => &map[*offset..*offset + *len],
            VoxelBytes::Owned(bytes) => bytes,
        }
    }

    /// Number of voxel bytes.
    pub fn len(&self) -> usize {
        self.as_slice().len()
    }

    /// True when there are no voxel bytes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// True when the bytes are a memory map of a file rather than owned in RAM.
    pub fn is_mapped(&self) -> bool {
        matches!(self, VoxelBytes::Mapped { .. })
    }

    /// For mapped bytes: an error when the file no longer holds the mapped region (reading
    /// it would raise SIGBUS). Owned bytes always pass.
    pub fn check_still_mapped(&self) -> Result<(), VolumeError> {
        let VoxelBytes::Mapped { offset, len, file, path, .. } = self else {
            return Ok(());
        };
        let needed = (*offset as u64).saturating_add(*len as u64);
        let found = file.metadata().map_err(|e| VolumeError::io(e, path))?.len();
        if found < needed {
            return Err(VolumeError::Shrunk { expected: needed, found, path: path.clone() });
        }
        Ok(())
    }
}

fn read_region(mut file: File, path: &Path, offset: u64, len: usize) -> Result<VoxelBytes, VolumeError> {
    use std::io::{Read, Seek, SeekFrom};
    file.seek(SeekFrom::Start(offset)).map_err(|e| VolumeError::io(e, path))?;
    let mut bytes = super::limits::zeroed(len, path)?;
    file.read_exact(&mut bytes).map_err(|e| VolumeError::io(e, path))?;
    Ok(VoxelBytes::Owned(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mapped_file_that_shrinks_is_an_error_not_a_crash() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("v_16x16x16_uint8.raw");
        std::fs::write(&path, vec![9u8; 4096]).unwrap();
        let bytes = VoxelBytes::map_region(&path, 0, 4096).unwrap();
        assert!(bytes.is_mapped());
        bytes.check_still_mapped().unwrap();
        std::fs::OpenOptions::new().write(true).open(&path).unwrap().set_len(100).unwrap();
        let error = bytes.check_still_mapped().unwrap_err();
        assert!(matches!(error, VolumeError::Shrunk { expected: 4096, found: 100, .. }), "{error}");
        assert!(error.to_string().ends_with(&format!("in {}", path.display())), "{error}");
        assert!(VoxelBytes::Owned(vec![1, 2]).check_still_mapped().is_ok());
    }

    #[test]
    fn an_opened_volume_reports_its_file_shrinking() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("v_16x16x16_uint8.raw");
        std::fs::write(&path, vec![9u8; 4096]).unwrap();
        let volume = crate::volume::open(&path, &crate::volume::OpenOptions::default()).unwrap();
        assert!(volume.is_memory_mapped());
        volume.check_still_mapped().unwrap();
        std::fs::OpenOptions::new().write(true).open(&path).unwrap().set_len(0).unwrap();
        assert!(matches!(volume.check_still_mapped(), Err(VolumeError::Shrunk { found: 0, .. })));
    }
}
