//! placeholder
use super::{Volume, VolumeError};
use std::path::Path;

#[derive(Clone, Debug, Default)]
pub struct OpenOptions {}

pub fn open(path: &Path, _options: &OpenOptions) -> Result<Volume, VolumeError> {
    Err(VolumeError::UnknownFormat {
        hint: "not yet".into(),
        path: path.to_path_buf(),
    })
}
