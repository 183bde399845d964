//! NIfTI-1: `.nii` (single file, magic `n+1`), `.hdr`/`.img` pairs (magic `ni1`), and `.nii.gz`.
//!
//! Follows the NIfTI-1 header layout (348 bytes). The byte order is detected from
//! `sizeof_hdr`; `pixdim[1..3]` gives the spacing (0 becomes 1 mm with a warning; NaN,
//! infinite and absurd values are refused); `scl_slope`/`scl_inter` become the volume's
//! [`ValueScale`] (slope 0 or NaN means "no scaling", as the standard and nibabel say; a
//! scale that makes every value non-finite is refused). Uncompressed data is memory-mapped at
//! `vox_offset`; gzip files are decompressed for the caller to cache. The data must end the
//! file (the `.img` of a pair, the decompressed stream): bytes after it are refused, as in
//! every reader.
//!
//! The sform or qform becomes the volume's patient orientation ([`super::orientation`]); the
//! grid itself stays as stored. Sizes and offsets are checked before use and gzip data is
//! decoded within [`super::limits`]; the `.img` of a pair must lie beside its `.hdr`.
//!
//! Never: resamples the grid to the qform/sform, or reads a series of volumes (`dim[4]` > 1),
//! vector or colour data (`dim[5]` > 1, RGB datatypes): those are refused, as NRRD and
//! MetaImage files with more than one value per voxel are.

use super::limits::{self, ReadLimits};
use super::{ByteOrder, ValueScale, Volume, VolumeError, VoxelBytes, VoxelType, checked_voxel_count};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Size of a NIfTI-1 header.
pub const HEADER_BYTES: usize = 348;

/// A parsed NIfTI-1 header.
#[derive(Clone, Debug, PartialEq)]
pub struct NiftiHeader {
    /// Voxels along x, y, z (`dim[1..=3]`).
    pub dims: [usize; 3],
    /// Voxel spacing along x, y, z in millimetres (`pixdim[1..=3]`).
    pub spacing_mm: [f64; 3],
    /// Scalar type of each voxel (`datatype`).
    pub voxel_type: VoxelType,
    /// Byte order of the header and data, told by which order reads `sizeof_hdr` as 348.
    pub byte_order: ByteOrder,
    /// `scl_slope` and `scl_inter`, the map from stored to physical values.
    pub scale: ValueScale,
    /// Byte offset of the data in the `.nii`, or in the `.img` for a pair.
    pub data_offset: u64,
    /// True for a `.hdr`/`.img` pair.
    pub separate_image_file: bool,
    /// From the sform or qform (see [`super::orientation::from_nifti`]).
    pub orientation: Option<super::PatientOrientation>,
    /// What the reader assumed where the header is silent or unusual (a zero `pixdim`), one
    /// sentence each, for [`Volume::warnings`].
    pub warnings: Vec<String>,
}

/// Parses a NIfTI-1 header from the first 348 bytes of `bytes`.
pub fn parse_header(bytes: &[u8], path: &Path) -> Result<NiftiHeader, VolumeError> {
    if bytes.len() < HEADER_BYTES {
        return Err(VolumeError::DataSize { expected: HEADER_BYTES, found: bytes.len(), path: path.to_path_buf() });
    }
    let byte_order = if i32::from_le_bytes(bytes[0..4].try_into().unwrap_or_default()) == 348 {
        ByteOrder::Little
    } else if i32::from_be_bytes(bytes[0..4].try_into().unwrap_or_default()) == 348 {
        ByteOrder::Big
    } else {
        return Err(VolumeError::UnknownFormat {
            hint: "sizeof_hdr is not 348 in either byte order (not NIfTI-1)".into(),
            path: path.to_path_buf(),
        });
    };
    let reader = FieldReader { bytes, byte_order };
    let magic = &bytes[344..348];
    let separate_image_file = match magic {
        b"n+1\0" => false,
        b"ni1\0" => true,
        _ => {
            return Err(VolumeError::header(
                "magic",
                format!("{:?} is neither 'n+1' nor 'ni1'", String::from_utf8_lossy(magic)),
                path,
            ));
        }
    };
    // dim[0] is the number of dimensions; dim[1..=7] the sizes.
    let rank = reader.i16(40);
    if !(1..=7).contains(&rank) {
        return Err(VolumeError::header("dim[0]", format!("{rank} is not between 1 and 7"), path));
    }
    let mut dims = [1usize; 3];
    for (axis, dim) in dims.iter_mut().enumerate().take((rank as usize).min(3)) {
        let size = reader.i16(42 + 2 * axis);
        if size < 1 {
            return Err(VolumeError::header(format!("dim[{}]", axis + 1), format!("{size} is not positive"), path));
        }
        *dim = size as usize;
    }
    // dim[4] counts volumes in time, dim[5] components per voxel (a vector or RGB field),
    // dim[6..=7] further axes: a scalar 3-D volume has 1 in each, as NRRD and MetaImage need.
    for higher in 3..rank as usize {
        let size = reader.i16(42 + 2 * higher);
        if size > 1 {
            return Err(VolumeError::Unsupported {
                what: if higher == 4 {
                    "NIfTI vector or multi-component data (only one scalar per voxel is read)"
                } else {
                    "NIfTI series of volumes (only one 3-D volume is read)"
                },
                value: format!("dim[{}] = {size}", higher + 1),
                path: path.to_path_buf(),
            });
        }
    }
    let datatype = reader.i16(70);
    let voxel_type = match datatype {
        2 => VoxelType::U8,
        4 => VoxelType::I16,
        8 => VoxelType::I32,
        16 => VoxelType::F32,
        64 => VoxelType::F64,
        256 => VoxelType::I8,
        512 => VoxelType::U16,
        768 => VoxelType::U32,
        128 | 2304 => {
            return Err(VolumeError::Unsupported {
                what: "NIfTI colour datatype (only one scalar per voxel is read)",
                value: format!("{datatype} ({})", if datatype == 128 { "RGB24" } else { "RGBA32" }),
                path: path.to_path_buf(),
            });
        }
        other => {
            return Err(VolumeError::Unsupported {
                what: "NIfTI datatype code",
                value: other.to_string(),
                path: path.to_path_buf(),
            });
        }
    };
    let bitpix = reader.i16(72);
    if bitpix as usize != voxel_type.size_bytes() * 8 {
        return Err(VolumeError::header("bitpix", format!("{bitpix} does not match datatype {datatype}"), path));
    }
    checked_voxel_count(dims, voxel_type, path)?;
    let (spacing_mm, spacing_warning) = spacing(&reader, dims, path)?;
    let vox_offset = reader.f32(108);
    if !(vox_offset.is_finite() && vox_offset >= 0.0) || (!separate_image_file && vox_offset < HEADER_BYTES as f32) {
        return Err(VolumeError::header("vox_offset", format!("{vox_offset} is not a valid data offset"), path));
    }
    let (scale, scale_warning) = scale(reader.f32(112) as f64, reader.f32(116) as f64, path)?;
    let orientation = super::orientation::from_nifti(&reader.transform(), path);
    Ok(NiftiHeader {
        dims,
        spacing_mm,
        voxel_type,
        byte_order,
        scale,
        data_offset: vox_offset as u64,
        separate_image_file,
        orientation,
        warnings: spacing_warning.into_iter().chain(scale_warning).collect(),
    })
}

/// `pixdim[1..=3]` as the spacing. Negative values count by their size (the direction is the
/// qform's). Zero means the writer did not say: 1 mm is used, with a warning along an axis of
/// more than one voxel (the scan may look stretched or squashed; along a single slice nothing
/// changes). NaN, infinite and absurd values are refused ([`super::check_spacing`]).
fn spacing(reader: &FieldReader, dims: [usize; 3], path: &Path) -> Result<([f64; 3], Option<String>), VolumeError> {
    let mut spacing_mm = [1.0f64; 3];
    let mut unknown = Vec::new();
    for (axis, spacing) in spacing_mm.iter_mut().enumerate() {
        let value = reader.f32(76 + 4 * (axis + 1)) as f64;
        if value == 0.0 {
            if dims[axis] > 1 {
                unknown.push(axis);
            }
        } else {
            *spacing = value.abs();
        }
    }
    super::check_spacing(spacing_mm, path)?;
    let warning = (!unknown.is_empty()).then(|| {
        let fields: Vec<String> = unknown.iter().map(|&axis| format!("pixdim[{}]", axis + 1)).collect();
        let names: Vec<&str> = unknown.iter().map(|&axis| ["x", "y", "z"][axis]).collect();
        let known: Vec<String> =
            (0..3).filter(|axis| !unknown.contains(axis)).map(|axis| format!("{} mm", spacing_mm[axis])).collect();
        let beside = if known.is_empty() { String::new() } else { format!(" beside {}", known.join(" and ")) };
        format!(
            "{} is 0 (the file gives no spacing along {}); shown at 1 mm{beside}, so the scan may look stretched or squashed",
            fields.join(" and "),
            names.join(" and ")
        )
    });
    Ok((spacing_mm, warning))
}

/// `scl_slope` and `scl_inter` as the value scale. A slope of 0 means "not scaled" (the
/// standard), and so does NaN (nibabel writes NaN, NaN for unscaled data and reads a NaN slope
/// as unscaled): the values are used as stored, with a warning when a finite non-zero intercept
/// is then left unused. An infinite slope, or a valid slope with a NaN or infinite intercept,
/// would make every value non-finite, and is refused (nibabel refuses the latter too).
fn scale(slope: f64, intercept: f64, path: &Path) -> Result<(ValueScale, Option<String>), VolumeError> {
    if slope.is_infinite() {
        return Err(VolumeError::header("scl_slope", format!("{slope} would make every value infinite"), path));
    }
    if slope == 0.0 || slope.is_nan() {
        let unused = intercept.is_finite() && intercept != 0.0;
        let warning = unused.then(|| {
            format!(
                "scl_slope is {slope} (not scaled), so scl_inter {intercept} is not applied; values are shown as stored"
            )
        });
        return Ok((ValueScale::IDENTITY, warning));
    }
    if !intercept.is_finite() {
        return Err(VolumeError::header(
            "scl_inter",
            format!("{intercept} beside scl_slope {slope} would make every value {intercept}"),
            path,
        ));
    }
    Ok((ValueScale { slope, intercept }, None))
}

struct FieldReader<'a> {
    bytes: &'a [u8],
    byte_order: ByteOrder,
}

impl FieldReader<'_> {
    fn i16(&self, offset: usize) -> i16 {
        let raw = [self.bytes[offset], self.bytes[offset + 1]];
        match self.byte_order {
            ByteOrder::Little => i16::from_le_bytes(raw),
            ByteOrder::Big => i16::from_be_bytes(raw),
        }
    }

    fn f32(&self, offset: usize) -> f32 {
        let raw = [self.bytes[offset], self.bytes[offset + 1], self.bytes[offset + 2], self.bytes[offset + 3]];
        match self.byte_order {
            ByteOrder::Little => f32::from_le_bytes(raw),
            ByteOrder::Big => f32::from_be_bytes(raw),
        }
    }

    /// The qform and sform fields (offsets of the NIfTI-1 header, 252..328).
    fn transform(&self) -> super::orientation::NiftiTransform {
        let f64_at = |offset: usize| self.f32(offset) as f64;
        super::orientation::NiftiTransform {
            qform_code: self.i16(252),
            sform_code: self.i16(254),
            quaternion_bcd: [f64_at(256), f64_at(260), f64_at(264)],
            qoffset_mm: [f64_at(268), f64_at(272), f64_at(276)],
            qfac: f64_at(76),
            srow: std::array::from_fn(|row| std::array::from_fn(|column| f64_at(280 + 16 * row + 4 * column))),
        }
    }
}

/// What reading a NIfTI file produced; `decoded` marks gzip data the caller should cache.
pub struct NiftiRead {
    /// The volume read.
    pub volume: Volume,
    /// True when gzip data was decompressed into memory rather than mapped.
    pub decoded: bool,
}

/// Reads `.nii`, `.hdr` (with its `.img`) or `.nii.gz` with the default [`ReadLimits`].
pub fn read(path: &Path) -> Result<NiftiRead, VolumeError> {
    read_with(path, &ReadLimits::default())
}

/// Reads `.nii`, `.hdr` (with its `.img`) or `.nii.gz`; the `.img` and gzip data obey `limits`.
pub fn read_with(path: &Path, limits: &ReadLimits) -> Result<NiftiRead, VolumeError> {
    if is_gzip(path)? {
        return read_gzip(path, limits);
    }
    let head = limits::read_head(path, HEADER_BYTES as u64)?;
    let header = parse_header(&head, path)?;
    let data_path = data_path(path, &header, limits)?;
    let length = checked_voxel_count(header.dims, header.voxel_type, path)? * header.voxel_type.size_bytes();
    let bytes = VoxelBytes::map_final_region(&data_path, header.data_offset, length)?;
    let mut volume =
        Volume::new(header.dims, header.spacing_mm, header.voxel_type, header.byte_order, header.scale, bytes, path)?;
    volume.orientation = header.orientation;
    volume.warnings = header.warnings;
    Ok(NiftiRead { volume, decoded: false })
}

/// The file the voxels are in: the `.nii` itself, or the checked `.img` beside a `.hdr`.
pub fn data_path(path: &Path, header: &NiftiHeader, limits: &ReadLimits) -> Result<PathBuf, VolumeError> {
    if !header.separate_image_file {
        return Ok(path.to_path_buf());
    }
    let image = image_file_for(path);
    let name = image.file_name().map(PathBuf::from).unwrap_or(image);
    limits::detached_data_file(path, &name, limits)
}

fn read_gzip(path: &Path, limits: &ReadLimits) -> Result<NiftiRead, VolumeError> {
    let (file, file_len) = limits::open_regular(path)?;
    let mut decoder = flate2::read::MultiGzDecoder::new(std::io::BufReader::new(file));
    let mut head = Vec::with_capacity(HEADER_BYTES);
    (&mut decoder)
        .take(HEADER_BYTES as u64)
        .read_to_end(&mut head)
        .map_err(|e| VolumeError::Decompress { source: e, path: path.to_path_buf() })?;
    let header = parse_header(&head, path)?;
    if header.separate_image_file {
        return Err(VolumeError::header("magic", "a gzip file must be a single-file NIfTI ('n+1')", path));
    }
    let length = checked_voxel_count(header.dims, header.voxel_type, path)? * header.voxel_type.size_bytes();
    let skip = header.data_offset.saturating_sub(HEADER_BYTES as u64);
    limits::check_deflate_can_hold(header.data_offset, length as u64, file_len, path)?;
    let data = limits::decode_exactly(decoder, skip, length, limits, path)?;
    let mut volume = Volume::new(
        header.dims,
        header.spacing_mm,
        header.voxel_type,
        header.byte_order,
        header.scale,
        VoxelBytes::Owned(data),
        path,
    )?;
    volume.orientation = header.orientation;
    volume.warnings = header.warnings;
    Ok(NiftiRead { volume, decoded: true })
}

/// True when the file starts with the gzip magic bytes.
pub fn is_gzip(path: &Path) -> Result<bool, VolumeError> {
    let mut magic = [0u8; 2];
    let (mut file, _) = limits::open_regular(path)?;
    let read = file.read(&mut magic).map_err(|e| VolumeError::io(e, path))?;
    Ok(read == 2 && magic == [0x1f, 0x8b])
}

/// The `.img` beside a `.hdr` (same stem, matching the extension's case).
fn image_file_for(header_path: &Path) -> PathBuf {
    let upper = header_path.extension().is_some_and(|e| e == "HDR");
    header_path.with_extension(if upper { "IMG" } else { "img" })
}

#[cfg(test)]
mod tests;
