//! The NRRD writer: attached headers with raw little- or big-endian data, written atomically.
//! A volume with a patient orientation is written in `space: left-posterior-superior` with its
//! `space directions` and `space origin` ([`orientation::nrrd_space_fields`]), so the import
//! cache and `volasso import` keep it; without one, `space dimension: 3` and axis-aligned
//! directions, which say nothing about the patient.

use super::type_name;
use crate::atomic_file::write_atomically;
use crate::volume::{ByteOrder, PatientOrientation, Volume, VolumeError, VoxelType, checked_voxel_count, orientation};
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

/// The header of a raw-encoded attached NRRD for `dims`, `spacing_mm`, `orientation` and
/// `voxel_type`.
pub fn header_text(
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    orientation: Option<&PatientOrientation>,
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
    let space = match orientation {
        Some(orientation) => orientation::nrrd_space_fields(orientation, spacing_mm),
        None => format!(
            "space dimension: 3\nspace directions: ({},0,0) (0,{},0) (0,0,{})\n",
            spacing_mm[0], spacing_mm[1], spacing_mm[2]
        ),
    };
    text.push_str(&format!(
        "type: {}\ndimension: 3\nsizes: {} {} {}\n{space}kinds: domain domain domain\nendian: {endian}\nencoding: raw\n\n",
        type_name(voxel_type),
        dims[0],
        dims[1],
        dims[2],
    ));
    text
}

/// Writes raw voxel `bytes` as an attached NRRD at `path`, atomically: a temporary file beside
/// it is written, flushed and renamed over `path`, so a crash leaves either the old file or the
/// whole new one. The file says nothing about the patient; [`write_on_grid`] does.
pub fn write(
    path: &Path,
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    voxel_type: VoxelType,
    byte_order: ByteOrder,
    bytes: &[u8],
    comment: &str,
) -> Result<(), VolumeError> {
    write_with_header(
        path,
        dims,
        voxel_type,
        bytes,
        &header_text(dims, spacing_mm, None, voxel_type, byte_order, comment),
    )
}

/// Writes `bytes` (voxels of `voxel_type` on the grid of `grid`: its dims, spacing and patient
/// orientation) as an attached NRRD at `path`, atomically. Label and colour volumes written
/// this way lie on their scan in other viewers.
pub fn write_on_grid(
    path: &Path,
    grid: &Volume,
    voxel_type: VoxelType,
    byte_order: ByteOrder,
    bytes: &[u8],
    comment: &str,
) -> Result<(), VolumeError> {
    let header = header_text(grid.dims, grid.spacing_mm, grid.orientation.as_ref(), voxel_type, byte_order, comment);
    write_with_header(path, grid.dims, voxel_type, bytes, &header)
}

fn write_with_header(
    path: &Path,
    dims: [usize; 3],
    voxel_type: VoxelType,
    bytes: &[u8],
    header: &str,
) -> Result<(), VolumeError> {
    let voxel_count = checked_voxel_count(dims, voxel_type, path)?;
    if bytes.len() != voxel_count * voxel_type.size_bytes() {
        return Err(VolumeError::DataSize {
            expected: voxel_count * voxel_type.size_bytes(),
            found: bytes.len(),
            path: path.to_path_buf(),
        });
    }
    write_atomically(path, |file| {
        file.write_all(header.as_bytes())?;
        file.write_all(bytes)
    })
    .map_err(|source| VolumeError::Write { source, path: path.to_path_buf() })
}

/// Writes a whole volume (its physical values for scaled volumes, as `float32`) to `path`.
pub fn write_volume(path: &Path, volume: &Volume, comment: &str) -> Result<(), VolumeError> {
    if volume.scale.is_identity() {
        write_on_grid(path, volume, volume.voxel_type, volume.byte_order, volume.raw_bytes(), comment)
    } else {
        let mut values = vec![0f32; volume.voxel_count()];
        volume.read_f32(0, &mut values);
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        write_on_grid(path, volume, VoxelType::F32, ByteOrder::Little, &bytes, comment)
    }
}
