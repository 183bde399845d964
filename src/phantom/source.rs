//! Where a volume comes from: a file or folder, or the built-in demo phantom under the name
//! [`DEMO_VOLUME`] (unless a file of that name exists). The command line, the chooser and the
//! autosave all name volumes this way, and [`VolumeSource::open`] is the one place "demo" is
//! turned into voxels.
//!
//! Never: decodes a file itself (that is `volume::open`), or ranks slices.

use crate::volume::{OpenOptions, Volume, VolumeError};
use std::path::{Path, PathBuf};

/// The volume name that means the built-in demo phantom (unless a file of that name exists).
pub const DEMO_VOLUME: &str = "demo";

/// Where a volume comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum VolumeSource {
    /// The built-in CT foot phantom ([`super::demo_foot`]).
    Demo,
    /// A path [`crate::volume::open()`] reads: a volume file or a DICOM series.
    Path(PathBuf),
}

impl VolumeSource {
    /// The source a command line or a saved session names: [`DEMO_VOLUME`] is the demo unless
    /// a file of that name exists.
    pub fn from_path(path: &Path) -> VolumeSource {
        if path.as_os_str() == DEMO_VOLUME && !path.exists() {
            VolumeSource::Demo
        } else {
            VolumeSource::Path(path.to_path_buf())
        }
    }

    /// What autosave writes: "demo" or the path.
    pub fn key(&self) -> String {
        match self {
            VolumeSource::Demo => DEMO_VOLUME.to_string(),
            VolumeSource::Path(path) => path.display().to_string(),
        }
    }

    /// The source an autosave's key names.
    pub fn from_key(key: &str) -> VolumeSource {
        VolumeSource::from_path(Path::new(key))
    }

    /// The name a person reads: the demo's description or the file name.
    pub fn name(&self) -> String {
        match self {
            VolumeSource::Demo => "Demo: CT foot phantom".to_string(),
            VolumeSource::Path(path) => path
                .file_name()
                .map(|name| name.to_string_lossy().into_owned())
                .unwrap_or_else(|| path.display().to_string()),
        }
    }

    /// The volume: the demo phantom generated, or the file opened with `options`.
    pub fn open(&self, options: &OpenOptions) -> Result<Volume, VolumeError> {
        match self {
            VolumeSource::Demo => Ok(super::demo_foot().volume),
            VolumeSource::Path(path) => crate::volume::open(path, options),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demo_names_the_phantom_unless_a_file_of_that_name_exists() {
        assert_eq!(VolumeSource::from_path(Path::new(DEMO_VOLUME)), VolumeSource::Demo);
        assert_eq!(VolumeSource::from_key(&VolumeSource::Demo.key()), VolumeSource::Demo);
        let source = VolumeSource::from_key("/data/ct.nrrd");
        assert_eq!(source, VolumeSource::Path("/data/ct.nrrd".into()));
        assert_eq!(source.name(), "ct.nrrd");
        assert_eq!(source.key(), "/data/ct.nrrd");
        let folder = tempfile::tempdir().unwrap();
        let missing = VolumeSource::Path(folder.path().join("missing.nrrd"));
        assert!(missing.open(&OpenOptions::default()).is_err());
        assert_eq!(VolumeSource::Demo.open(&OpenOptions::default()).unwrap().dims, [192, 128, 96]);
    }
}
