//! NIfTI-1: `.nii` (single file, magic `n+1`), `.hdr`/`.img` pairs (magic `ni1`), and `.nii.gz`.
//!
//! Follows the NIfTI-1 header layout (348 bytes). The byte order is detected from
//! `sizeof_hdr`; `pixdim[1..3]` gives the spacing; `scl_slope`/`scl_inter` become the volume's
//! [`ValueScale`] (slope 0 means "no scaling", as the standard says). Uncompressed data is
//! memory-mapped at `vox_offset`; gzip files are decompressed for the caller to cache.
//!
//! The sform or qform becomes the volume's patient orientation ([`super::orientation`]); the
//! grid itself stays as stored. Sizes and offsets are checked before use and gzip data is
//! decoded within [`super::limits`]; the `.img` of a pair must lie beside its `.hdr`.
//!
//! Never: resamples the grid to the qform/sform, or reads a 4-D series beyond its first volume.

use super::limits::{self, Beyond, ReadLimits};
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
    /// True when dims 4..7 hold more than the one volume read (its data may follow).
    pub more_volumes: bool,
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
    let mut more_volumes = false;
    for higher in 3..rank as usize {
        let size = reader.i16(42 + 2 * higher);
        if size > 1 {
            more_volumes = true;
            log::warn!("{} has {} volumes along dim[{}]; only the first is used", path.display(), size, higher + 1);
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
    let mut spacing_mm = [1.0f64; 3];
    for (axis, spacing) in spacing_mm.iter_mut().enumerate() {
        let value = reader.f32(76 + 4 * (axis + 1)) as f64;
        // pixdim of 0 along a singleton axis is common; a spacing is still needed for rendering.
        *spacing = if value.is_finite() && value != 0.0 { value.abs() } else { 1.0 };
    }
    let vox_offset = reader.f32(108);
    if !(vox_offset.is_finite() && vox_offset >= 0.0) || (!separate_image_file && vox_offset < HEADER_BYTES as f32) {
        return Err(VolumeError::header("vox_offset", format!("{vox_offset} is not a valid data offset"), path));
    }
    let slope = reader.f32(112) as f64;
    let intercept = reader.f32(116) as f64;
    // The standard: scl_slope 0 (or not finite) means the values are used as stored.
    let scale = if slope != 0.0 && slope.is_finite() && intercept.is_finite() {
        ValueScale { slope, intercept }
    } else {
        ValueScale::IDENTITY
    };
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
        more_volumes,
    })
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
    let bytes = VoxelBytes::map_region(&data_path, header.data_offset, length)?;
    let mut volume =
        Volume::new(header.dims, header.spacing_mm, header.voxel_type, header.byte_order, header.scale, bytes, path)?;
    volume.orientation = header.orientation;
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
    let beyond = if header.more_volumes { Beyond::Ignore } else { Beyond::Refuse };
    let data = limits::decode_exactly(decoder, skip, length, beyond, limits, path)?;
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
mod tests {
    use super::*;

    /// A minimal little-endian single-file header for `dims` of `datatype`.
    pub(crate) fn header_bytes(
        dims: [i16; 3],
        datatype: i16,
        bitpix: i16,
        pixdim: [f32; 3],
        slope: f32,
        intercept: f32,
    ) -> Vec<u8> {
        let mut h = vec![0u8; 352];
        h[0..4].copy_from_slice(&348i32.to_le_bytes());
        h[40..42].copy_from_slice(&3i16.to_le_bytes());
        for (i, d) in dims.iter().enumerate() {
            h[42 + 2 * i..44 + 2 * i].copy_from_slice(&d.to_le_bytes());
        }
        h[70..72].copy_from_slice(&datatype.to_le_bytes());
        h[72..74].copy_from_slice(&bitpix.to_le_bytes());
        for (i, p) in pixdim.iter().enumerate() {
            h[80 + 4 * i..84 + 4 * i].copy_from_slice(&p.to_le_bytes());
        }
        h[108..112].copy_from_slice(&352f32.to_le_bytes());
        h[112..116].copy_from_slice(&slope.to_le_bytes());
        h[116..120].copy_from_slice(&intercept.to_le_bytes());
        h[344..348].copy_from_slice(b"n+1\0");
        h
    }

    #[test]
    fn parses_a_little_endian_header_with_scaling() {
        let bytes = header_bytes([4, 3, 2], 4, 16, [0.5, 0.75, 2.0], 2.0, -1024.0);
        let header = parse_header(&bytes, Path::new("t.nii")).unwrap();
        assert_eq!(header.dims, [4, 3, 2]);
        assert_eq!(header.voxel_type, VoxelType::I16);
        assert_eq!(header.spacing_mm, [0.5, 0.75, 2.0]);
        assert_eq!(header.scale, ValueScale { slope: 2.0, intercept: -1024.0 });
        assert_eq!(header.data_offset, 352);
    }

    #[test]
    fn slope_zero_means_no_scaling() {
        let bytes = header_bytes([4, 3, 2], 2, 8, [1.0; 3], 0.0, 5.0);
        assert_eq!(parse_header(&bytes, Path::new("t.nii")).unwrap().scale, ValueScale::IDENTITY);
    }

    #[test]
    fn refuses_bad_headers() {
        let good = header_bytes([4, 3, 2], 4, 16, [1.0; 3], 1.0, 0.0);
        type Corruption = Box<dyn Fn(&mut Vec<u8>)>;
        let cases: Vec<(&str, Corruption)> = vec![
            ("short", Box::new(|h| h.truncate(100))),
            ("sizeof_hdr", Box::new(|h| h[0] = 7)),
            ("magic", Box::new(|h| h[344] = b'x')),
            ("datatype", Box::new(|h| h[70..72].copy_from_slice(&1024i16.to_le_bytes()))),
            ("bitpix", Box::new(|h| h[72..74].copy_from_slice(&8i16.to_le_bytes()))),
            ("negative dim", Box::new(|h| h[42..44].copy_from_slice(&(-4i16).to_le_bytes()))),
            ("rank", Box::new(|h| h[40..42].copy_from_slice(&9i16.to_le_bytes()))),
            ("vox_offset", Box::new(|h| h[108..112].copy_from_slice(&f32::NAN.to_le_bytes()))),
        ];
        for (name, corrupt) in cases {
            let mut bytes = good.clone();
            corrupt(&mut bytes);
            assert!(parse_header(&bytes, Path::new("t.nii")).is_err(), "{name} accepted");
        }
    }

    proptest::proptest! {
        /// Any header bytes parse or fail cleanly; an accepted header never promises an
        /// overflowing voxel count or a data offset inside the header of a single file.
        #[test]
        fn parse_never_panics(mut bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 348..400), little in proptest::prelude::any::<bool>()) {
            if little {
                bytes[0..4].copy_from_slice(&348i32.to_le_bytes());
                bytes[344..348].copy_from_slice(b"n+1\0");
            }
            if let Ok(header) = parse_header(&bytes, Path::new("t.nii")) {
                proptest::prop_assert!(checked_voxel_count(header.dims, header.voxel_type, Path::new("t")).is_ok());
                proptest::prop_assert!(header.separate_image_file || header.data_offset >= HEADER_BYTES as u64);
            }
        }
    }
}
