//! The one error type of the volume stage. Variants carry the facts as fields; the path goes
//! last in every message so that the CLI's one sentence reads "what, then where".

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum VolumeError {
    #[error("cannot read {}: {source}", path.display())]
    Io { source: std::io::Error, path: PathBuf },
    #[error("header field '{field}' is invalid: {problem}, in {}", path.display())]
    Header { field: String, problem: String, path: PathBuf },
    #[error("header lacks the required field '{field}', in {}", path.display())]
    MissingField { field: &'static str, path: PathBuf },
    #[error("unsupported {what} '{value}', in {}", path.display())]
    Unsupported { what: &'static str, value: String, path: PathBuf },
    #[error("dimensions {}x{}x{} are invalid: {problem}, in {}", dims[0], dims[1], dims[2], path.display())]
    BadDimensions { dims: [u64; 3], problem: &'static str, path: PathBuf },
    #[error("voxel spacing {value} along axis {axis} is not a positive finite number, in {}", path.display())]
    BadSpacing { axis: usize, value: f64, path: PathBuf },
    #[error("the header promises {expected} bytes of voxel data but {found} are there (truncated or lying file), in {}", path.display())]
    DataSize { expected: usize, found: usize, path: PathBuf },
    #[error("gzip data is corrupt or truncated ({source}), in {}", path.display())]
    Decompress { source: std::io::Error, path: PathBuf },
    #[error("cannot tell the format of {}: {hint}", path.display())]
    UnknownFormat { hint: String, path: PathBuf },
    #[error("DICOM: {problem}, in {}", path.display())]
    Dicom { problem: String, path: PathBuf },
    #[error("the volume needs {bytes} bytes in memory, above the ceiling of {ceiling} bytes for decoded data, in {}", path.display())]
    TooLarge { bytes: u64, ceiling: u64, path: PathBuf },
    #[error("cannot allocate {bytes} bytes for the voxel data (not enough memory), in {}", path.display())]
    OutOfMemory { bytes: u64, path: PathBuf },
    #[error("the header promises {expected} bytes of voxel data but {available} bytes of {encoding} data can hold at most {most} (a lying header), in {}", path.display())]
    CannotHold { expected: u64, encoding: &'static str, available: u64, most: u64, path: PathBuf },
    #[error("the data holds more than the {expected} bytes the header promises (its sizes or type are wrong), in {}", path.display())]
    ExtraData { expected: u64, path: PathBuf },
    #[error("the data file {} lies outside the header's folder {} (pass --allow-external-data to read it anyway), in {}", data_file.display(), folder.display(), path.display())]
    ExternalData { data_file: PathBuf, folder: PathBuf, path: PathBuf },
    #[error("not a regular file (devices, pipes and sockets are never read as volumes): {}", path.display())]
    NotRegularFile { path: PathBuf },
    #[error("DICOM series with a missing slice: {problem}; not opened, since the volume would have a hole (pass --allow-gaps to resample across it), in {}", path.display())]
    SeriesGap { problem: String, path: PathBuf },
    #[error("the file shrank to {found} bytes after it was mapped ({expected} are needed); open it again, in {}", path.display())]
    Shrunk { expected: u64, found: u64, path: PathBuf },
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
