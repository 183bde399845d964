//! placeholder: the DICOM series reader is being written on the wip-dicom branch.
use super::{Volume, VolumeError};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Resample {
    #[default]
    Auto,
    Refuse,
}

#[derive(Clone, Debug, Default)]
pub struct DicomOptions {
    pub series_uid: Option<String>,
    pub resample: Resample,
    pub slice_spacing_mm: Option<f64>,
}

pub struct DicomImport {
    pub volume: Volume,
    pub warnings: Vec<String>,
    pub series_uid: String,
    pub description: String,
    pub files: Vec<PathBuf>,
}

pub fn read_series(path: &Path, _options: &DicomOptions) -> Result<DicomImport, VolumeError> {
    Err(VolumeError::Dicom { problem: "not yet".into(), path: path.to_path_buf() })
}

pub fn looks_like_dicom(path: &Path) -> bool {
    path.is_dir()
}
