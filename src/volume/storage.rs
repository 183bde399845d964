//! Where voxel bytes live: a read-only memory map of a file region, or owned bytes.
//!
//! Mapping is the point of the whole volume stage: opening the 16 MiB engine volume must not
//! make it resident. When a map cannot be made (a pipe, a file system without mmap), the
//! region is read instead and a warning says so, as ripgrep's searcher falls back.

use super::VolumeError;
use memmap2::Mmap;
use std::fs::File;
use std::path::Path;

/// The voxel bytes of a volume.
#[derive(Debug)]
pub enum VoxelBytes {
    /// `len` bytes at `offset` of a mapped file.
    Mapped { map: Mmap, offset: usize, len: usize },
    /// Bytes in RAM (generated volumes, small or decoded data).
    Owned(Vec<u8>),
}

impl VoxelBytes {
    /// Maps `len` bytes at `offset` of `path`, after checking that the file holds them.
    /// Falls back to reading them when the map fails.
    pub fn map_region(path: &Path, offset: u64, len: usize) -> Result<VoxelBytes, VolumeError> {
        let file = File::open(path).map_err(|e| VolumeError::io(e, path))?;
        let file_len = file.metadata().map_err(|e| VolumeError::io(e, path))?.len();
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
        // as it was at open time.
        let mapped = unsafe { Mmap::map(&file) };
        match mapped {
            Ok(map) => {
                #[cfg(unix)]
                {
                    // Whole-volume passes read front to back; tell the kernel.
                    let _ = map.advise(memmap2::Advice::Sequential);
                }
                Ok(VoxelBytes::Mapped { map, offset: offset as usize, len })
            }
            Err(error) => {
                log::warn!("memory map of {} failed ({error}); reading it into memory instead", path.display());
                read_region(file, path, offset, len)
            }
        }
    }

    pub fn as_slice(&self) -> &[u8] {
        match self {
            VoxelBytes::Mapped { map, offset, len } => &map[*offset..*offset + *len],
            VoxelBytes::Owned(bytes) => bytes,
        }
    }

    pub fn len(&self) -> usize {
        self.as_slice().len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn is_mapped(&self) -> bool {
        matches!(self, VoxelBytes::Mapped { .. })
    }
}

fn read_region(mut file: File, path: &Path, offset: u64, len: usize) -> Result<VoxelBytes, VolumeError> {
    use std::io::{Read, Seek, SeekFrom};
    file.seek(SeekFrom::Start(offset)).map_err(|e| VolumeError::io(e, path))?;
    let mut bytes = vec![0u8; len];
    file.read_exact(&mut bytes).map_err(|e| VolumeError::io(e, path))?;
    Ok(VoxelBytes::Owned(bytes))
}
