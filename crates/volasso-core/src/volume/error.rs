//! The one error type of the volume stage. Variants carry the facts as fields; the path goes
//! last in every message so that the CLI's one sentence reads "what, then where".

use std::path::PathBuf;

/// Why a volume could not be opened, read or written.
#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    /// Reading the file failed at the operating system.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The underlying I/O error.
        source: std::io::Error,
        /// The file it happened on.
        path: PathBuf,
    },
    /// Writing a file (an output, a cache entry) failed at the operating system.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The underlying I/O error.
        source: std::io::Error,
        /// The file being written.
        path: PathBuf,
    },
    /// A header field is present but its value is malformed or out of range.
    #[error("header field '{field}' is invalid: {problem}, in {}", path.display())]
    Header {
        /// The header field's name as the file spells it.
        field: String,
        /// What is wrong with its value.
        problem: String,
        /// The header file.
        path: PathBuf,
    },
    /// A header field is given twice with different values: which one the writer meant cannot
    /// be told.
    #[error("header field '{field}' is given twice with different values ('{}', then '{}'), in {}", values[0], values[1], path.display())]
    RepeatedField {
        /// The field's name as the file first spells it.
        field: String,
        /// Its first value, then the other (boxed: the error stays small).
        values: Box<[String; 2]>,
        /// The header file.
        path: PathBuf,
    },
    /// A value of ASCII-encoded data cannot be stored in the declared type (out of range, a
    /// fraction for an integer type, not a number): never clamped or rounded.
    #[error("the ASCII value '{value}' on line {line} {problem} {}, in {}", voxel_type.name(), path.display())]
    AsciiValue {
        /// The value as written (its first 60 characters).
        value: String,
        /// The line of the data file it is on, from 1.
        line: u64,
        /// Why it cannot be stored.
        problem: AsciiProblem,
        /// The declared voxel type.
        voxel_type: super::VoxelType,
        /// The data file.
        path: PathBuf,
    },
    /// The header lacks a field the format requires.
    #[error("header lacks the required field '{field}', in {}", path.display())]
    MissingField {
        /// The missing field's name.
        field: &'static str,
        /// The header file.
        path: PathBuf,
    },
    /// The file uses a feature volasso does not read (a voxel type, encoding, transfer syntax...).
    #[error("unsupported {what} '{value}', in {}", path.display())]
    Unsupported {
        /// What kind of feature it is (for example "encoding").
        what: &'static str,
        /// The value the file declares.
        value: String,
        /// The file.
        path: PathBuf,
    },
    /// The declared voxel counts are zero, not three-dimensional or overflow memory sizes.
    #[error("dimensions {}x{}x{} are invalid: {problem}, in {}", dims[0], dims[1], dims[2], path.display())]
    BadDimensions {
        /// Voxel counts along x, y, z as declared.
        dims: [u64; 3],
        /// Why they are unusable.
        problem: &'static str,
        /// The file.
        path: PathBuf,
    },
    /// A voxel spacing is zero, negative, NaN, infinite, or outside the range any scan has
    /// ([`super::SMALLEST_SPACING_MM`]..=[`super::LARGEST_SPACING_MM`]).
    #[error("voxel spacing {} mm along {} is outside {}..{} mm (a wrong unit or a corrupt header), in {}", readable(*value), ["x", "y", "z"].get(*axis).unwrap_or(&"an axis"), super::SMALLEST_SPACING_MM, super::LARGEST_SPACING_MM, path.display())]
    BadSpacing {
        /// The axis (0 = x, 1 = y, 2 = z).
        axis: usize,
        /// The declared spacing along it.
        value: f64,
        /// The file.
        path: PathBuf,
    },
    /// Every voxel is NaN or infinite: there is no value to show or classify.
    #[error("every one of the {voxels} voxels is NaN or infinite: the volume holds no value to show, in {}", path.display())]
    NoFiniteValue {
        /// The number of voxels (all of them non-finite).
        voxels: u64,
        /// The file.
        path: PathBuf,
    },
    /// A value lies beyond `f32`'s range, in which every stage after reading computes.
    #[error("the value {}{} is beyond the range of 32-bit floats (±3.4e38) in which volumes are processed, in {}", readable(*value), if *scaled { " (after the file's value scaling)" } else { "" }, path.display())]
    ValueOverflow {
        /// The smallest or largest value found beyond the range.
        value: f64,
        /// True when the file's value scale (slope, intercept) took it there.
        scaled: bool,
        /// The file.
        path: PathBuf,
    },
    /// The voxel data is shorter than the header declares (a truncated or lying file).
    #[error("the header promises {expected} bytes of voxel data but {found} are there (truncated or lying file), in {}", path.display())]
    DataSize {
        /// Bytes of voxel data the header declares.
        expected: usize,
        /// Bytes actually present.
        found: usize,
        /// The data file.
        path: PathBuf,
    },
    /// The header declares compressed data, but the data start with neither gzip's nor
    /// zlib's header: they are raw (or something else), not a corrupt stream.
    #[error("the data are not compressed as '{declaration}' declares (they start with the bytes {start}, not a gzip or zlib header), in {}", path.display())]
    NotCompressed {
        /// The header's words that declare the compression (`encoding: gzip`).
        declaration: &'static str,
        /// The first bytes of the data, in hexadecimal.
        start: String,
        /// The data file.
        path: PathBuf,
    },
    /// The gzip or zlib stream is corrupt or ends early.
    #[error("compressed (gzip or zlib) data is corrupt or truncated ({source}), in {}", path.display())]
    Decompress {
        /// The decoder's error.
        source: std::io::Error,
        /// The compressed file.
        path: PathBuf,
    },
    /// Neither the file name nor its first bytes say which format it is.
    #[error("cannot tell the format of {}: {hint}", path.display())]
    UnknownFormat {
        /// What was looked at and what to do about it.
        hint: String,
        /// The file.
        path: PathBuf,
    },
    /// A DICOM file or series cannot be read as one volume.
    #[error("DICOM: {problem}, in {}", path.display())]
    Dicom {
        /// What is wrong, in words.
        problem: String,
        /// The DICOM file or folder.
        path: PathBuf,
    },
    /// The decoded voxels would need more memory than the ceiling allows.
    #[error("the volume needs {bytes} bytes in memory, above the ceiling of {ceiling} bytes for decoded data, in {}", path.display())]
    TooLarge {
        /// Bytes the decoded voxels need.
        bytes: u64,
        /// The largest decoded size allowed, in bytes.
        ceiling: u64,
        /// The file.
        path: PathBuf,
    },
    /// The allocation for the voxel data failed.
    #[error("cannot allocate {bytes} bytes for the voxel data (not enough memory), in {}", path.display())]
    OutOfMemory {
        /// Bytes that could not be allocated.
        bytes: u64,
        /// The file.
        path: PathBuf,
    },
    /// The encoded data is too small to decode to the size the header declares.
    #[error("the header promises {expected} bytes of voxel data but {available} bytes of {encoding} data can hold at most {most} (a lying header), in {}", path.display())]
    CannotHold {
        /// Bytes of decoded voxel data the header declares.
        expected: u64,
        /// The data's encoding ("compressed" or "ASCII").
        encoding: &'static str,
        /// Bytes of encoded data in the file.
        available: u64,
        /// The most decoded bytes that much encoded data can yield.
        most: u64,
        /// The file.
        path: PathBuf,
    },
    /// The data holds more bytes than the header declares (wrong sizes or voxel type).
    #[error("the data holds more than the {expected} bytes the header promises (its sizes or type are wrong), in {}", path.display())]
    ExtraData {
        /// Bytes of voxel data the header declares.
        expected: u64,
        /// The file.
        path: PathBuf,
    },
    /// The file holds bytes after the voxel data its header promises (wrong sizes, type or
    /// data offset).
    #[error("the data holds {extra} bytes more than the {expected} bytes the header promises (its sizes, type or data offset are wrong), in {}", path.display())]
    TrailingData {
        /// Bytes of voxel data the header declares.
        expected: u64,
        /// Bytes in the file after them.
        extra: u64,
        /// The data file.
        path: PathBuf,
    },
    /// A detached header names a data file outside its own folder, and that was not allowed.
    #[error("the data file {} lies outside the header's folder {} (pass --allow-external-data to read it anyway), in {}", data_file.display(), folder.display(), path.display())]
    ExternalData {
        /// The data file the header names, resolved.
        data_file: PathBuf,
        /// The header's folder.
        folder: PathBuf,
        /// The header file.
        path: PathBuf,
    },
    /// The path is a device, pipe, socket or other non-regular file.
    #[error("not a regular file (devices, pipes and sockets are never read as volumes): {}", path.display())]
    NotRegularFile {
        /// The path.
        path: PathBuf,
    },
    /// A DICOM series misses a slice, and resampling across gaps was not allowed.
    #[error("DICOM series with a missing slice: {problem}; not opened, since the volume would have a hole (pass --allow-gaps to resample across it), in {}", path.display())]
    SeriesGap {
        /// Where the gap is, in words.
        problem: String,
        /// The series' folder.
        path: PathBuf,
    },
    /// The import cache folder cannot be used (a file in its place, no permission).
    #[error("the import cache folder is unusable: {problem} (set --cache-dir or VOLASSO_CACHE_DIR to a folder), in {}", path.display())]
    CacheFolder {
        /// What is wrong with it, in words.
        problem: String,
        /// The folder.
        path: PathBuf,
    },
    /// The file was truncated by someone else after it was memory-mapped.
    #[error("the file shrank to {found} bytes after it was mapped ({expected} are needed); open it again, in {}", path.display())]
    Shrunk {
        /// Bytes the mapping needs.
        expected: u64,
        /// Bytes the file holds now.
        found: u64,
        /// The file.
        path: PathBuf,
    },
}

impl VolumeError {
    /// Wraps an I/O error with the path it happened on.
    pub fn io(source: std::io::Error, path: impl Into<PathBuf>) -> VolumeError {
        VolumeError::Io { source, path: path.into() }
    }

    /// A header field with a bad value.
    pub fn header(field: impl Into<String>, problem: impl Into<String>, path: impl Into<PathBuf>) -> VolumeError {
        VolumeError::Header { field: field.into(), problem: problem.into(), path: path.into() }
    }
}

/// A number for a message: as written in the usual range, in short scientific notation beyond
/// it (`1e30`, `7.0000e41`, not thirty digits).
fn readable(value: f64) -> String {
    if !value.is_finite() || value == 0.0 || (1e-3..1e7).contains(&value.abs()) {
        return value.to_string();
    }
    let short = format!("{value:e}");
    if short.len() <= 12 { short } else { format!("{value:.4e}") }
}

/// Why an ASCII value cannot be stored in its voxel type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum AsciiProblem {
    /// The text is not a number.
    #[error("is not a number, as needed for")]
    NotANumber,
    /// A fraction (or NaN, infinity) where an integer type is declared.
    #[error("is not a whole number, as needed for")]
    NotWhole,
    /// Beyond the smallest or largest value of the type.
    #[error("is outside the range of")]
    OutOfRange,
}
