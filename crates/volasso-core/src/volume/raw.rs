//! Headerless raw volumes: the Open SciVis naming convention `name_XxYxZ_type.raw`, or any file
//! with explicit dimensions and type (`--dims X,Y,Z --type T [--spacing ...]`).
//!
//! Raw files are little-endian, x fastest (`interfaces.md`). The file must hold exactly the
//! promised bytes: a shorter file is truncated, a longer one lies about what it is, and both
//! are refused rather than guessed at.
//!
//! Never: guesses dimensions from the file size.

use super::{ByteOrder, ValueScale, Volume, VolumeError, VoxelBytes, VoxelType, checked_voxel_count};
use std::path::Path;

/// Dimensions and type a raw file's name promises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RawNaming {
    /// Voxels along x, y, z (the `XxYxZ` part).
    pub dims: [usize; 3],
    /// Scalar type of each voxel (the `type` part, an Open SciVis name).
    pub voxel_type: VoxelType,
}

/// Parses `name_XxYxZ_type.raw` (the name may contain more underscores). `None` when the name
/// does not follow the convention.
pub fn parse_name(file_name: &str) -> Option<RawNaming> {
    let stem = file_name.strip_suffix(".raw")?;
    let mut parts = stem.rsplitn(3, '_');
    let type_name = parts.next()?;
    let dims_text = parts.next()?;
    parts.next()?;
    let voxel_type = VoxelType::from_name(type_name)?;
    let dims: Vec<usize> = dims_text.split('x').map(|d| d.parse().ok()).collect::<Option<_>>()?;
    let dims: [usize; 3] = dims.try_into().ok()?;
    Some(RawNaming { dims, voxel_type })
}

/// Maps a raw file with known dimensions, type and spacing.
pub fn read(path: &Path, naming: RawNaming, spacing_mm: [f64; 3]) -> Result<Volume, VolumeError> {
    let length = checked_voxel_count(naming.dims, naming.voxel_type, path)? * naming.voxel_type.size_bytes();
    let (_, file_len) = super::limits::open_regular(path)?;
    if file_len != length as u64 {
        return Err(VolumeError::DataSize { expected: length, found: file_len as usize, path: path.to_path_buf() });
    }
    let bytes = VoxelBytes::map_region(path, 0, length)?;
    Volume::new(naming.dims, spacing_mm, naming.voxel_type, ByteOrder::Little, ValueScale::IDENTITY, bytes, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_open_scivis_names() {
        assert_eq!(
            parse_name("engine_256x256x256_uint8.raw"),
            Some(RawNaming { dims: [256, 256, 256], voxel_type: VoxelType::U8 })
        );
        assert_eq!(
            parse_name("cranium_ct_256x256x108_int16.raw"),
            Some(RawNaming { dims: [256, 256, 108], voxel_type: VoxelType::I16 })
        );
        assert_eq!(parse_name("x_1x2x3_float64.raw").map(|n| n.voxel_type), Some(VoxelType::F64));
    }

    #[test]
    fn rejects_other_names() {
        for name in [
            "engine.raw",
            "engine_256x256_uint8.raw",
            "e_256x256x256_uint64.raw",
            "e_axbxc_uint8.raw",
            "_256x256x256.raw",
            "e_1x2x3_uint8.dat",
            "e_-1x2x3_uint8.raw",
        ] {
            assert_eq!(parse_name(name), None, "{name}");
        }
    }
}
