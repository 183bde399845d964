//! NRRD: read (attached `.nrrd` and detached `.nhdr`) and write (the import cache, label and
//! RGBA volumes).
//!
//! Follows the teem NRRD format specification (NRRD0001..NRRD0005). Raw-encoded data is
//! memory-mapped in place; gzip data is decompressed (the caller caches it as a raw NRRD);
//! ASCII data is parsed into memory, each value stored exactly or refused (`ascii`). Header
//! parsing ([`parse_header`]) is a pure function over bytes, so it is property-tested and
//! fuzzed without touching files. A field given twice with different values is refused
//! (`super::fields`); the data must end its file (bytes after it are refused, as more
//! decompressed or ASCII data is).
//!
//! Every size, offset and skip is checked before it is used (see [`super::limits`]): byte and
//! line skips with checked arithmetic, gzip and ASCII data against what the file can hold and
//! the decoding ceiling, a detached `data file` only beside its header.
//!
//! Never: resamples, or reads more than the header promises.

use super::fields::HeaderFields;
use super::limits::{self, Deflate, ReadLimits};
use super::{ByteOrder, ValueScale, Volume, VolumeError, VoxelBytes, VoxelType, checked_voxel_count};
use std::path::{Path, PathBuf};

/// How the voxel data is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NrrdEncoding {
    /// Uncompressed binary data (`raw`).
    Raw,
    /// Gzip-compressed binary data (`gzip` or `gz`).
    Gzip,
    /// Whitespace-separated decimal text (`ascii`, `text` or `txt`).
    Ascii,
}

/// A parsed NRRD header: what the data is and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct NrrdHeader {
    /// Scalar type of each voxel (`type`).
    pub voxel_type: VoxelType,
    /// Voxels along x, y, z (`sizes`).
    pub dims: [usize; 3],
    /// Voxel spacing along x, y, z in millimetres (`spacings` or `space directions`).
    pub spacing_mm: [f64; 3],
    /// How the voxel data is encoded (`encoding`).
    pub encoding: NrrdEncoding,
    /// Byte order of multi-byte voxels (`endian`).
    pub byte_order: ByteOrder,
    /// `data file`, relative to the header's folder; `None` when the data is attached.
    pub data_file: Option<PathBuf>,
    /// `byte skip`; `None` for `-1` (the data ends the file).
    pub byte_skip: Option<u64>,
    /// `line skip`: text lines to skip in the data file before the data.
    pub line_skip: u64,
    /// Offset of the first byte after the blank line that ends the header (attached data
    /// starts here); `None` when no blank line was found (fine for a detached header).
    pub header_length: Option<usize>,
    /// From `space`, `space directions` and `space origin` (see [`super::orientation`]).
    pub orientation: Option<super::PatientOrientation>,
    /// What the reader assumed where the header is silent, one sentence each (a spatial
    /// axis without a spacing), for [`Volume::warnings`].
    pub warnings: Vec<String>,
}

/// Maps every NRRD type spelling to a voxel type; `None` for names this product does not
/// support (64-bit integers, `block`).
pub fn type_from_name(name: &str) -> Option<VoxelType> {
    Some(match name {
        "signed char" | "int8" | "int8_t" => VoxelType::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => VoxelType::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => VoxelType::I16,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => VoxelType::U16,
        "int" | "signed int" | "int32" | "int32_t" => VoxelType::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => VoxelType::U32,
        "float" => VoxelType::F32,
        "double" => VoxelType::F64,
        _ => return None,
    })
}

fn type_name(voxel_type: VoxelType) -> &'static str {
    match voxel_type {
        VoxelType::I8 => "int8",
        VoxelType::U8 => "uint8",
        VoxelType::I16 => "int16",
        VoxelType::U16 => "uint16",
        VoxelType::I32 => "int32",
        VoxelType::U32 => "uint32",
        VoxelType::F32 => "float",
        VoxelType::F64 => "double",
    }
}

/// Parses the header at the start of `bytes` (the whole `.nhdr`, or the head of a `.nrrd`).
/// `path` only names the file in errors.
pub fn parse_header(bytes: &[u8], path: &Path) -> Result<NrrdHeader, VolumeError> {
    let header_error = |field: &str, problem: String| VolumeError::header(field, problem, path);
    if !bytes.starts_with(b"NRRD000") || bytes.len() < 8 || !(b'1'..=b'5').contains(&bytes[7]) {
        return Err(VolumeError::UnknownFormat {
            hint: "no NRRD0001..NRRD0005 magic at the start".into(),
            path: path.to_path_buf(),
        });
    }
    let mut fields = HeaderFields::default();
    let mut position = 0usize;
    let mut header_length = None;
    let mut first = true;
    while position < bytes.len() {
        let end = bytes[position..].iter().position(|&b| b == b'\n').map(|i| position + i);
        let line_end = end.unwrap_or(bytes.len());
        let line = &bytes[position..line_end];
        position = end.map_or(bytes.len(), |e| e + 1);
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        if first {
            first = false;
            continue;
        }
        if line.is_empty() {
            header_length = Some(position);
            break;
        }
        if line.starts_with(b"#") {
            continue;
        }
        let line = std::str::from_utf8(line).map_err(|_| header_error("header", "a header line is not text".into()))?;
        // Key/value pairs (`key:=value`) carry no geometry; skip them.
        if line.contains(":=") {
            continue;
        }
        let Some((field, value)) = line.split_once(": ") else {
            return Err(header_error("header", format!("line '{}' is not 'field: value'", truncate(line))));
        };
        fields.insert(field_key(field), field, value, path)?;
    }
    let get = |name: &str| fields.get(name);

    let type_value = get("type").ok_or(VolumeError::MissingField { field: "type", path: path.to_path_buf() })?;
    let voxel_type = type_from_name(type_value).ok_or_else(|| VolumeError::Unsupported {
        what: "NRRD type",
        value: type_value.to_string(),
        path: path.to_path_buf(),
    })?;

    let dimension: usize = get("dimension")
        .ok_or(VolumeError::MissingField { field: "dimension", path: path.to_path_buf() })?
        .parse()
        .map_err(|_| header_error("dimension", "not a whole number".into()))?;
    let sizes_value = get("sizes").ok_or(VolumeError::MissingField { field: "sizes", path: path.to_path_buf() })?;
    let sizes: Vec<usize> = sizes_value
        .split_whitespace()
        .map(|s| s.parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| header_error("sizes", format!("'{}' are not whole numbers", truncate(sizes_value))))?;
    if sizes.len() != dimension {
        return Err(header_error("sizes", format!("{} sizes for dimension {dimension}", sizes.len())));
    }
    // A volume is 3-D; a 2-D image is a one-slice volume; a leading axis of size 1 (a
    // one-component "vector") is dropped.
    let spatial_axes: Vec<usize> = match dimension {
        2 => vec![0, 1],
        3 => vec![0, 1, 2],
        4 if sizes[0] == 1 => vec![1, 2, 3],
        _ => {
            return Err(VolumeError::Unsupported {
                what: "NRRD dimension (a scalar volume needs 2 or 3 axes)",
                value: format!("{dimension} with sizes {sizes_value}"),
                path: path.to_path_buf(),
            });
        }
    };
    let mut dims = [1usize; 3];
    for (i, &axis) in spatial_axes.iter().enumerate() {
        dims[i] = sizes[axis];
    }
    checked_voxel_count(dims, voxel_type, path)?;

    let (spacing_mm, spacing_warning) =
        parse_spacing(get("space directions"), get("spacings"), &spatial_axes, dimension, path)?;
    let orientation =
        super::orientation::from_nrrd(get("space"), get("space directions"), get("space origin"), &spatial_axes, path);

    let encoding =
        match get("encoding").ok_or(VolumeError::MissingField { field: "encoding", path: path.to_path_buf() })? {
            "raw" => NrrdEncoding::Raw,
            "gzip" | "gz" => NrrdEncoding::Gzip,
            "ascii" | "text" | "txt" => NrrdEncoding::Ascii,
            other => {
                return Err(VolumeError::Unsupported {
                    what: "NRRD encoding",
                    value: other.to_string(),
                    path: path.to_path_buf(),
                });
            }
        };
    let byte_order = match get("endian") {
        Some("little") => ByteOrder::Little,
        Some("big") => ByteOrder::Big,
        Some(other) => {
            return Err(header_error("endian", format!("'{}' is neither little nor big", truncate(other))));
        }
        None if voxel_type.size_bytes() == 1 || encoding == NrrdEncoding::Ascii => ByteOrder::Little,
        None => {
            return Err(VolumeError::MissingField { field: "endian", path: path.to_path_buf() });
        }
    };
    let data_file = match get("data file") {
        None => None,
        Some(value) if value.starts_with("LIST") || value.contains('%') || value.split_whitespace().count() > 1 => {
            return Err(VolumeError::Unsupported {
                what: "multi-file NRRD 'data file'",
                value: value.to_string(),
                path: path.to_path_buf(),
            });
        }
        Some(value) => Some(PathBuf::from(value)),
    };
    let byte_skip =
        match get("byte skip") {
            None => Some(0),
            Some("-1") => None,
            Some(value) => Some(value.parse::<u64>().map_err(|_| {
                header_error("byte skip", format!("'{}' is not -1 or a whole number", truncate(value)))
            })?),
        };
    if byte_skip.is_none() && encoding != NrrdEncoding::Raw {
        return Err(header_error("byte skip", "-1 is only valid with raw encoding".into()));
    }
    let line_skip = match get("line skip") {
        None => 0,
        Some(value) => value
            .parse::<u64>()
            .map_err(|_| header_error("line skip", format!("'{}' is not a whole number", truncate(value))))?,
    };
    Ok(NrrdHeader {
        voxel_type,
        dims,
        spacing_mm,
        encoding,
        byte_order,
        data_file,
        byte_skip,
        line_skip,
        header_length,
        orientation,
        warnings: spacing_warning.into_iter().collect(),
    })
}

/// A field name as compared: lowercase, the one-word spellings teem also reads (`datafile`,
/// `byteskip`, `lineskip`) as their two-word forms, so that both spellings of a field count as
/// the same field given twice.
fn field_key(field: &str) -> String {
    let key = field.trim().to_ascii_lowercase();
    match key.as_str() {
        "datafile" => "data file".into(),
        "byteskip" => "byte skip".into(),
        "lineskip" => "line skip".into(),
        _ => key,
    }
}

/// The first 60 characters of a header value, for messages.
fn truncate(text: &str) -> String {
    text.chars().take(60).collect()
}

/// What reading a NRRD file produced: a volume (mapped for raw data), and whether its data had to
/// be decoded (gzip), which is the caller's cue to cache it.
pub struct NrrdRead {
    /// The volume read.
    pub volume: Volume,
    /// True when the data was decoded into memory (gzip or ASCII) rather than mapped.
    pub decoded: bool,
}

/// Reads a `.nrrd` or `.nhdr` file with the default [`ReadLimits`].
pub fn read(path: &Path) -> Result<NrrdRead, VolumeError> {
    read_with(path, &ReadLimits::default())
}

/// Reads a `.nrrd` or `.nhdr` file; a detached data file and decoded data obey `limits`.
pub fn read_with(path: &Path, limits: &ReadLimits) -> Result<NrrdRead, VolumeError> {
    let head = limits::read_head(path, 1 << 16)?;
    let header = parse_header(&head, path)?;
    let data_path = data_path(path, &header, limits)?;
    let attached_offset = match (&header.data_file, header.header_length) {
        (Some(_), _) => 0,
        (None, Some(length)) => length as u64,
        (None, None) => {
            return Err(VolumeError::header(
                "header",
                "no blank line ends the header and no 'data file' is named",
                path,
            ));
        }
    };
    let voxel_count = checked_voxel_count(header.dims, header.voxel_type, path)?;
    let expected = voxel_count * header.voxel_type.size_bytes();
    let (file, file_len) = limits::open_regular(&data_path)?;
    let mut offset = attached_offset;
    if header.line_skip > 0 {
        offset = skip_lines(&file, &data_path, offset, header.line_skip)?;
    }
    let (bytes, decoded) = match header.encoding {
        NrrdEncoding::Raw => {
            let offset = match header.byte_skip {
                Some(skip) => offset.checked_add(skip).ok_or_else(|| {
                    VolumeError::header(
                        "byte skip",
                        format!("{skip} bytes after offset {offset} pass any file's end"),
                        path,
                    )
                })?,
                None => file_len.checked_sub(expected as u64).ok_or(VolumeError::DataSize {
                    expected,
                    found: file_len as usize,
                    path: data_path.clone(),
                })?,
            };
            (VoxelBytes::map_final_region(&data_path, offset, expected)?, false)
        }
        NrrdEncoding::Gzip => {
            let skip = header.byte_skip.unwrap_or(0);
            let compressed = file_len.saturating_sub(offset);
            limits::check_deflate_can_hold(skip, expected as u64, compressed, &data_path)?;
            let mut reader = positioned(file, &data_path, offset)?;
            limits::check_compressed(&mut reader, &[Deflate::Gzip], "encoding: gzip", &data_path)?;
            let decoder = flate2::bufread::MultiGzDecoder::new(reader);
            (VoxelBytes::Owned(limits::decode_exactly(decoder, skip, expected, limits, &data_path)?), true)
        }
        NrrdEncoding::Ascii => {
            let available = file_len.saturating_sub(offset);
            let reader = positioned(file, &data_path, offset)?;
            // Lines are counted in the data file: the header's own (attached data), then the skipped.
            let header_lines = match (&header.data_file, header.header_length) {
                (None, Some(length)) => head[..length].iter().filter(|&&b| b == b'\n').count() as u64,
                _ => 0,
            };
            let first_line = 1 + header_lines + header.line_skip;
            let values =
                parse_ascii(reader, available, first_line, header.voxel_type, voxel_count, limits, &data_path)?;
            (VoxelBytes::Owned(values), false)
        }
    };
    let order = if header.encoding == NrrdEncoding::Ascii { ByteOrder::Little } else { header.byte_order };
    let mut volume =
        Volume::new(header.dims, header.spacing_mm, header.voxel_type, order, ValueScale::IDENTITY, bytes, path)?;
    volume.orientation = header.orientation;
    volume.warnings = header.warnings;
    Ok(NrrdRead { volume, decoded })
}

/// The file the voxel data is in: the header's own, or its checked `data file`.
pub fn data_path(path: &Path, header: &NrrdHeader, limits: &ReadLimits) -> Result<PathBuf, VolumeError> {
    match &header.data_file {
        Some(file) => limits::detached_data_file(path, file, limits),
        None => Ok(path.to_path_buf()),
    }
}

/// A buffered reader over `file` from `offset` on.
fn positioned(
    mut file: std::fs::File,
    path: &Path,
    offset: u64,
) -> Result<std::io::BufReader<std::fs::File>, VolumeError> {
    use std::io::{Seek, SeekFrom};
    file.seek(SeekFrom::Start(offset)).map_err(|e| VolumeError::io(e, path))?;
    Ok(std::io::BufReader::with_capacity(1 << 16, file))
}

/// The offset after `lines` more newlines from `offset`, read a buffer at a time.
fn skip_lines(file: &std::fs::File, path: &Path, offset: u64, lines: u64) -> Result<u64, VolumeError> {
    use std::io::BufRead;
    let clone = file.try_clone().map_err(|e| VolumeError::io(e, path))?;
    let mut reader = positioned(clone, path, offset)?;
    let (mut position, mut remaining) = (offset, lines);
    loop {
        let buffer = reader.fill_buf().map_err(|e| VolumeError::io(e, path))?;
        if buffer.is_empty() {
            return Err(VolumeError::header("line skip", format!("the data has fewer than {lines} lines"), path));
        }
        let mut consumed = buffer.len();
        for (i, _) in buffer.iter().enumerate().filter(|(_, b)| **b == b'\n') {
            remaining -= 1;
            if remaining == 0 {
                consumed = i + 1;
                break;
            }
        }
        position += consumed as u64;
        reader.consume(consumed);
        if remaining == 0 {
            return Ok(position);
        }
    }
}

mod ascii;
mod spacing;
mod write;

use ascii::parse_ascii;

use spacing::parse_spacing;
pub(crate) use spacing::split_direction_vectors;
pub use write::{header_text, push_value, write, write_on_grid, write_volume};

#[cfg(test)]
mod tests;
