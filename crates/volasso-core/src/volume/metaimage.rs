//! MetaImage (ITK): `.mha` (header and data in one file) and `.mhd` (header, data in a file it
//! names).
//!
//! The header is `Key = Value` lines ending with `ElementDataFile`; keys are compared without
//! regard to case, and a key given twice with different values is refused (`super::fields`).
//! Booleans (`BinaryDataByteOrderMSB`, its synonym `ElementByteOrderMSB`, `CompressedData`)
//! are `True`/`False` or `1`/`0` in any case; anything else is refused. Raw data is
//! memory-mapped; `CompressedData = True` (zlib, or gzip as ITK also reads) is decompressed for
//! the caller to cache, and data that start with neither header are named as not compressed.
//! The data must end the file (bytes after it, or after the compressed stream, are refused).
//! `TransformMatrix` (or `AnatomicalOrientation`) and `Offset` become the volume's patient
//! orientation ([`super::orientation`]).
//!
//! Sizes and offsets are checked before use and compressed data is decoded within
//! [`super::limits`]; a detached `ElementDataFile` must lie beside its header.
//!
//! Never: reads multi-channel images (`ElementNumberOfChannels` > 1) or lists of slice files.

use super::fields::HeaderFields;
use super::limits::{self, Deflate, ReadLimits};
use super::{ByteOrder, ValueScale, Volume, VolumeError, VoxelBytes, VoxelType, checked_voxel_count};
use std::path::{Path, PathBuf};

/// A parsed MetaImage header.
#[derive(Clone, Debug, PartialEq)]
pub struct MetaImageHeader {
    /// Voxels along x, y, z (`DimSize`).
    pub dims: [usize; 3],
    /// Voxel spacing along x, y, z in millimetres (`ElementSpacing`).
    pub spacing_mm: [f64; 3],
    /// Scalar type of each voxel (`ElementType`).
    pub voxel_type: VoxelType,
    /// Byte order of multi-byte voxels (`BinaryDataByteOrderMSB`).
    pub byte_order: ByteOrder,
    /// True when the data is zlib-compressed (`CompressedData`).
    pub compressed: bool,
    /// `None` for `LOCAL` (data follows the header in the same file).
    pub data_file: Option<PathBuf>,
    /// Bytes to skip in the data file; `None` for `HeaderSize = -1` (the data ends the file).
    pub header_size: Option<u64>,
    /// Where the header ends (local data starts here).
    pub header_length: usize,
    /// From `TransformMatrix` or `AnatomicalOrientation`, and `Offset` ([`super::orientation`]).
    pub orientation: Option<super::PatientOrientation>,
}

/// Parses the MetaImage header at the start of `bytes`.
pub fn parse_header(bytes: &[u8], path: &Path) -> Result<MetaImageHeader, VolumeError> {
    let mut fields = HeaderFields::default();
    let mut position = 0usize;
    let mut header_length = None;
    while position < bytes.len() {
        let end = bytes[position..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| position + i);
        let line = &bytes[position..end];
        position = (end + 1).min(bytes.len());
        let Ok(line) = std::str::from_utf8(line) else {
            return Err(VolumeError::UnknownFormat {
                hint: "a MetaImage header line is not text".into(),
                path: path.to_path_buf(),
            });
        };
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(VolumeError::header(
                "header",
                format!("line '{}' is not 'Key = Value'", line.chars().take(60).collect::<String>()),
                path,
            ));
        };
        let compared = key.trim().to_ascii_lowercase();
        let is_last = compared == "elementdatafile";
        fields.insert(compared, key, value, path)?;
        if is_last {
            header_length = Some(position);
            break;
        }
    }
    let Some(header_length) = header_length else {
        return Err(VolumeError::MissingField { field: "ElementDataFile", path: path.to_path_buf() });
    };
    let get = |name: &str| fields.get(&name.to_ascii_lowercase());
    let numbers = |name: &'static str| -> Result<Option<Vec<f64>>, VolumeError> {
        get(name)
            .map(|v| {
                v.split_whitespace()
                    .map(|t| t.parse::<f64>())
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|_| VolumeError::header(name, format!("'{v}' are not numbers"), path))
            })
            .transpose()
    };

    let rank: usize = get("NDims")
        .ok_or(VolumeError::MissingField { field: "NDims", path: path.to_path_buf() })?
        .parse()
        .map_err(|_| VolumeError::header("NDims", "not a whole number", path))?;
    if !(2..=3).contains(&rank) {
        return Err(VolumeError::Unsupported {
            what: "MetaImage NDims (2 or 3 supported)",
            value: rank.to_string(),
            path: path.to_path_buf(),
        });
    }
    let sizes = numbers("DimSize")?.ok_or(VolumeError::MissingField { field: "DimSize", path: path.to_path_buf() })?;
    if sizes.len() != rank || sizes.iter().any(|&s| s.fract() != 0.0 || !(0.0..=1e12).contains(&s)) {
        return Err(VolumeError::header("DimSize", format!("{sizes:?} are not {rank} whole sizes"), path));
    }
    let mut dims = [1usize; 3];
    for (d, s) in dims.iter_mut().zip(&sizes) {
        *d = *s as usize;
    }
    let element_type =
        get("ElementType").ok_or(VolumeError::MissingField { field: "ElementType", path: path.to_path_buf() })?;
    let voxel_type = match element_type {
        "MET_UCHAR" => VoxelType::U8,
        "MET_CHAR" => VoxelType::I8,
        "MET_USHORT" => VoxelType::U16,
        "MET_SHORT" => VoxelType::I16,
        "MET_UINT" => VoxelType::U32,
        "MET_INT" => VoxelType::I32,
        "MET_FLOAT" => VoxelType::F32,
        "MET_DOUBLE" => VoxelType::F64,
        other => {
            return Err(VolumeError::Unsupported {
                what: "MetaImage ElementType",
                value: other.to_string(),
                path: path.to_path_buf(),
            });
        }
    };
    checked_voxel_count(dims, voxel_type, path)?;
    if let Some(channels) = get("ElementNumberOfChannels")
        && channels != "1"
    {
        return Err(VolumeError::Unsupported {
            what: "MetaImage ElementNumberOfChannels",
            value: channels.to_string(),
            path: path.to_path_buf(),
        });
    }
    let mut spacing_mm = [1.0; 3];
    if let Some(spacing) = numbers("ElementSpacing")?.or(numbers("ElementSize")?) {
        if spacing.len() != rank {
            return Err(VolumeError::header(
                "ElementSpacing",
                format!("{} values for NDims {rank}", spacing.len()),
                path,
            ));
        }
        spacing_mm[..rank].copy_from_slice(&spacing);
    }
    let flag = |name: &'static str| get(name).map(|value| boolean(name, value, path)).transpose();
    let msb = match (flag("BinaryDataByteOrderMSB")?, flag("ElementByteOrderMSB")?) {
        (Some(binary), Some(element)) if binary != element => {
            return Err(VolumeError::header(
                "ElementByteOrderMSB",
                format!("says {element} where BinaryDataByteOrderMSB says {binary}: the byte order cannot be told"),
                path,
            ));
        }
        (binary, element) => binary.or(element).unwrap_or(false),
    };
    let byte_order = if msb { ByteOrder::Big } else { ByteOrder::Little };
    let compressed = flag("CompressedData")?.unwrap_or(false);
    let data_file = match get("ElementDataFile").unwrap_or("LOCAL") {
        "LOCAL" | "Local" | "local" => None,
        value if value.starts_with("LIST") || value.contains('%') || value.split_whitespace().count() > 1 => {
            return Err(VolumeError::Unsupported {
                what: "MetaImage ElementDataFile list",
                value: value.to_string(),
                path: path.to_path_buf(),
            });
        }
        value => Some(PathBuf::from(value)),
    };
    let header_size = match get("HeaderSize") {
        None => Some(0),
        Some("-1") => None,
        Some(v) => Some(
            v.parse::<u64>()
                .map_err(|_| VolumeError::header("HeaderSize", format!("'{v}' is not -1 or a whole number"), path))?,
        ),
    };
    let orientation = super::orientation::from_metaimage(
        get("TransformMatrix").or(get("Rotation")).or(get("Orientation")),
        get("AnatomicalOrientation"),
        get("Offset").or(get("Origin")).or(get("Position")),
        rank,
        path,
    );
    Ok(MetaImageHeader {
        dims,
        spacing_mm,
        voxel_type,
        byte_order,
        compressed,
        data_file,
        header_size,
        header_length,
        orientation,
    })
}

/// A MetaImage boolean: `True`, `1`, `False` or `0` (ITK writes `True`/`False`; any case).
/// Anything else is refused rather than read as false, which would silently read big-endian
/// data as little-endian or compressed data as raw.
fn boolean(name: &str, value: &str, path: &Path) -> Result<bool, VolumeError> {
    if value.eq_ignore_ascii_case("true") || value == "1" {
        Ok(true)
    } else if value.eq_ignore_ascii_case("false") || value == "0" {
        Ok(false)
    } else {
        Err(VolumeError::header(
            name,
            format!("'{}' is not True, False, 1 or 0", value.chars().take(60).collect::<String>()),
            path,
        ))
    }
}

/// What reading a MetaImage produced; `decoded` marks compressed data the caller should cache.
pub struct MetaImageRead {
    /// The volume read.
    pub volume: Volume,
    /// True when the data was decompressed into memory rather than mapped.
    pub decoded: bool,
}

/// Reads a `.mha` or `.mhd` with the default [`ReadLimits`].
pub fn read(path: &Path) -> Result<MetaImageRead, VolumeError> {
    read_with(path, &ReadLimits::default())
}

/// Reads a `.mha` or `.mhd`; a detached data file and compressed data obey `limits`.
pub fn read_with(path: &Path, limits: &ReadLimits) -> Result<MetaImageRead, VolumeError> {
    let head = limits::read_head(path, 1 << 16)?;
    let header = parse_header(&head, path)?;
    let (data_path, base) = match &header.data_file {
        Some(name) => (limits::detached_data_file(path, name, limits)?, 0u64),
        None => (path.to_path_buf(), header.header_length as u64),
    };
    let length = checked_voxel_count(header.dims, header.voxel_type, path)? * header.voxel_type.size_bytes();
    let offset_error = |skip: u64| {
        VolumeError::header("HeaderSize", format!("{skip} bytes after offset {base} pass any file's end"), path)
    };
    if header.compressed {
        let skip = header.header_size.unwrap_or(0);
        let start = base.checked_add(skip).ok_or_else(|| offset_error(skip))?;
        let (mut file, file_len) = limits::open_regular(&data_path)?;
        limits::check_deflate_can_hold(0, length as u64, file_len.saturating_sub(start), &data_path)?;
        std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(start)).map_err(|e| VolumeError::io(e, &data_path))?;
        let mut reader = std::io::BufReader::with_capacity(1 << 16, file);
        // ITK reads gzip as well as zlib here (its inflate detects the header).
        let wrapper = limits::check_compressed(
            &mut reader,
            &[Deflate::Zlib, Deflate::Gzip],
            "CompressedData = True",
            &data_path,
        )?;
        let data = if wrapper == Some(Deflate::Gzip) {
            limits::decode_exactly(flate2::bufread::MultiGzDecoder::new(reader), 0, length, limits, &data_path)?
        } else {
            let mut decoder = flate2::bufread::ZlibDecoder::new(reader);
            let data = limits::decode_exactly(&mut decoder, 0, length, limits, &data_path)?;
            // A zlib stream ends by itself; bytes after it are refused as trailing data.
            let after = std::io::BufRead::fill_buf(decoder.get_mut()).map_err(|e| VolumeError::io(e, &data_path))?;
            if !after.is_empty() {
                return Err(VolumeError::ExtraData { expected: length as u64, path: data_path });
            }
            data
        };
        let mut volume = Volume::new(
            header.dims,
            header.spacing_mm,
            header.voxel_type,
            header.byte_order,
            ValueScale::IDENTITY,
            VoxelBytes::Owned(data),
            path,
        )?;
        volume.orientation = header.orientation;
        return Ok(MetaImageRead { volume, decoded: true });
    }
    let offset = match header.header_size {
        Some(skip) => base.checked_add(skip).ok_or_else(|| offset_error(skip))?,
        None => {
            let (_, file_len) = limits::open_regular(&data_path)?;
            file_len.checked_sub(length as u64).ok_or(VolumeError::DataSize {
                expected: length,
                found: file_len as usize,
                path: data_path.clone(),
            })?
        }
    };
    let bytes = VoxelBytes::map_final_region(&data_path, offset, length)?;
    let mut volume = Volume::new(
        header.dims,
        header.spacing_mm,
        header.voxel_type,
        header.byte_order,
        ValueScale::IDENTITY,
        bytes,
        path,
    )?;
    volume.orientation = header.orientation;
    Ok(MetaImageRead { volume, decoded: false })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementSpacing = 0.5 0.5 2\nBinaryDataByteOrderMSB = True\nElementDataFile = LOCAL\n";

    #[test]
    fn parses_a_local_big_endian_header() {
        let header = parse_header(HEADER.as_bytes(), Path::new("t.mha")).unwrap();
        assert_eq!(header.dims, [4, 3, 2]);
        assert_eq!(header.voxel_type, VoxelType::I16);
        assert_eq!(header.spacing_mm, [0.5, 0.5, 2.0]);
        assert_eq!(header.byte_order, ByteOrder::Big);
        assert_eq!(header.data_file, None);
        assert_eq!(header.header_length, HEADER.len());
    }

    #[test]
    fn byte_order_and_compression_flags_take_every_spelling_or_are_refused() {
        for (value, expected) in [
            ("True", Some(true)),
            ("true", Some(true)),
            ("TRUE", Some(true)),
            ("1", Some(true)),
            ("False", Some(false)),
            ("false", Some(false)),
            ("0", Some(false)),
            ("yes", None),
            ("2", None),
            ("", None),
            ("T", None),
        ] {
            for field in ["BinaryDataByteOrderMSB", "ElementByteOrderMSB"] {
                let text = HEADER.replace("BinaryDataByteOrderMSB = True", &format!("{field} = {value}"));
                let parsed = parse_header(text.as_bytes(), Path::new("t.mha"));
                match expected {
                    Some(big) => assert_eq!(
                        parsed.unwrap().byte_order,
                        if big { ByteOrder::Big } else { ByteOrder::Little },
                        "{field} = {value}"
                    ),
                    None => assert!(
                        matches!(&parsed, Err(VolumeError::Header { field: f, .. }) if f == field),
                        "{field} = {value}: {:?}",
                        parsed.map(|h| h.byte_order)
                    ),
                }
            }
            let text = HEADER.replace("ElementDataFile", &format!("CompressedData = {value}\nElementDataFile"));
            let parsed = parse_header(text.as_bytes(), Path::new("t.mha")).map(|h| h.compressed);
            assert_eq!(parsed.ok(), expected, "CompressedData = {value}");
        }
        let both = HEADER.replace("ElementDataFile", "ElementByteOrderMSB = True\nElementDataFile");
        assert_eq!(parse_header(both.as_bytes(), Path::new("t.mha")).unwrap().byte_order, ByteOrder::Big);
        let conflict = HEADER.replace("ElementDataFile", "ElementByteOrderMSB = 0\nElementDataFile");
        assert!(parse_header(conflict.as_bytes(), Path::new("t.mha")).is_err());
    }

    #[test]
    fn a_key_given_twice_is_refused_unless_it_repeats_the_same_value() {
        for extra in [
            "DimSize = 4 3 4",
            "dimsize = 8 3 2",
            "ElementType = MET_UCHAR",
            "NDims = 2",
            "ElementSpacing = 1 1 1",
            "BinaryDataByteOrderMSB = False",
            "HeaderSize = 0\nHeaderSize = 8",
        ] {
            let text = HEADER.replace("ElementDataFile", &format!("{extra}\nElementDataFile"));
            let error = parse_header(text.as_bytes(), Path::new("t.mha")).unwrap_err();
            assert!(matches!(error, VolumeError::RepeatedField { .. }), "{extra}: {error}");
        }
        let same = HEADER.replace("ElementDataFile", "DIMSIZE = 4 3  2\nElementDataFile");
        assert_eq!(parse_header(same.as_bytes(), Path::new("t.mha")).unwrap().dims, [4, 3, 2]);
    }

    #[test]
    fn refuses_bad_headers() {
        for (name, text) in [
            ("no data file", HEADER.replace("ElementDataFile = LOCAL\n", "")),
            ("type", HEADER.replace("MET_SHORT", "MET_LONG_LONG")),
            ("ndims", HEADER.replace("NDims = 3", "NDims = 5")),
            ("sizes", HEADER.replace("4 3 2", "4 3")),
            ("fractional size", HEADER.replace("4 3 2", "4 3.5 2")),
            ("zero size", HEADER.replace("4 3 2", "4 0 2")),
            ("spacing", HEADER.replace("0.5 0.5 2", "0.5 x 2")),
            ("channels", HEADER.replace("ElementDataFile", "ElementNumberOfChannels = 3\nElementDataFile")),
            ("list", HEADER.replace("LOCAL", "LIST 2D")),
            ("no equals", HEADER.replace("NDims = 3", "NDims 3")),
        ] {
            assert!(parse_header(text.as_bytes(), Path::new("t.mha")).is_err(), "{name} accepted");
        }
    }

    proptest::proptest! {
        /// Random edits of a valid header parse or fail cleanly, never panic.
        #[test]
        fn parse_never_panics(position in 0usize..HEADER.len(), insert in "[ -~\n]{0,12}") {
            let mut text = HEADER.to_string();
            let position = (0..=position).rev().find(|&p| text.is_char_boundary(p)).unwrap_or(0);
            text.insert_str(position, &insert);
            if let Ok(header) = parse_header(text.as_bytes(), Path::new("t.mha")) {
                proptest::prop_assert!(checked_voxel_count(header.dims, header.voxel_type, Path::new("t")).is_ok());
            }
        }
    }
}
