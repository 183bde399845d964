//! The NRRD writer: attached headers with raw little- or big-endian data, written atomically.

use super::type_name;
use crate::atomic_file::write_atomically;
use crate::volume::{ByteOrder, Volume, VolumeError, VoxelType, checked_voxel_count};
use std::io::Write;
use std::path::Path;

/// Appends `value` as a little-endian `voxel_type` (saturating for integers).
pub fn push_value(bytes: &mut Vec<u8>, voxel_type: VoxelType, value: f64) {
    match voxel_type {
        VoxelType::U8 => bytes.push(value as u8),
        VoxelType::I8 => bytes.push(value as i8 as u8),
        VoxelType::U16 => bytes.extend((value as u16).to_le_bytes()),
        VoxelType::I16 => bytes.extend((value as i16).to_le_bytes()),
        VoxelType::U32 => bytes.extend((value as u32).to_le_bytes()),
        VoxelType::I32 => bytes.extend((value as i32).to_le_bytes()),
        VoxelType::F32 => bytes.extend((value as f32).to_le_bytes()),
        VoxelType::F64 => bytes.extend(value.to_le_bytes()),
    }
}

/// The header of a raw-encoded attached NRRD for `dims`, `spacing_mm` and `voxel_type`.
pub fn header_text(
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    voxel_type: VoxelType,
    byte_order: ByteOrder,
    comment: &str,
) -> String {
    let endian = match byte_order {
        ByteOrder::Little => "little",
        ByteOrder::Big => "big",
    };
    let mut text = String::from("NRRD0004\n");
    for line in comment.lines() {
        text.push_str(&format!("# {line}\n"));
    }
    text.push_str(&format!(
        "type: {}\ndimension: 3\nsizes: {} {} {}\nspace dimension: 3\nspace directions: ({},0,0) (0,{},0) (0,0,{})\nkinds: domain domain domain\nendian: {endian}\nencoding: raw\n\n",
        type_name(voxel_type),
        dims[0],
        dims[1],
        dims[2],
        spacing_mm[0],
        spacing_mm[1],
        spacing_mm[2],
    ));
    text
}

/// Writes raw voxel `bytes` as an attached NRRD at `path`, atomically: a temporary file beside
/// it is written, flushed and renamed over `path`, so a crash leaves either the old file or the
/// whole new one.
pub fn write(
    path: &Path,
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    voxel_type: VoxelType,
    byte_order: ByteOrder,
    bytes: &[u8],
    comment: &str,
) -> Result<(), VolumeError> {
    let voxel_count = checked_voxel_count(dims, voxel_type, path)?;
    if bytes.len() != voxel_count * voxel_type.size_bytes() {
        return Err(VolumeError::DataSize {
            expected: voxel_count * voxel_type.size_bytes(),
            found: bytes.len(),
            path: path.to_path_buf(),
        });
    }
    let header = header_text(dims, spacing_mm, voxel_type, byte_order, comment);
    write_atomically(path, |file| {
        file.write_all(header.as_bytes())?;
        file.write_all(bytes)
    })
    .map_err(|e| VolumeError::io(e, path))
}

/// Writes a whole volume (its physical values for scaled volumes, as `float32`) to `path`.
pub fn write_volume(path: &Path, volume: &Volume, comment: &str) -> Result<(), VolumeError> {
    if volume.scale.is_identity() {
        write(path, volume.dims, volume.spacing_mm, volume.voxel_type, volume.byte_order, volume.raw_bytes(), comment)
    } else {
        let mut values = vec![0f32; volume.voxel_count()];
        volume.read_f32(0, &mut values);
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        write(path, volume.dims, volume.spacing_mm, VoxelType::F32, ByteOrder::Little, &bytes, comment)
    }
}
