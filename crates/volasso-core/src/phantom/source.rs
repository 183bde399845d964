//! Where a volume comes from: a file or folder, or the built-in demo phantom under the name
//! [`DEMO_VOLUME`] (unless a file of that name exists). The command line, the chooser and the
//! autosave all name volumes this way, and [`VolumeSource::open`] is the one place "demo" is
//! turned into voxels.
//!
//! One series of a DICOM folder that holds several is a source of its own
//! ([`VolumeSource::Series`]); its key is the folder's path followed by [`SERIES_MARK`] and the
//! SeriesInstanceUID, which a DICOM UID (digits and dots) cannot be confused with.
//!
//! Never: decodes a file itself (that is `volume::open`), or ranks slices.

use crate::volume::{OpenOptions, Volume, VolumeError};
use std::path::{Path, PathBuf};

/// The volume name that means the built-in demo phantom (unless a file of that name exists).
pub const DEMO_VOLUME: &str = "demo";

/// What separates a DICOM folder's path from a series' UID in a [`VolumeSource::Series`] key.
pub const SERIES_MARK: &str = "#series=";

/// Where a volume comes from.
#[derive(Clone, Debug)]
pub enum VolumeSource {
    /// The built-in CT foot phantom ([`super::demo_foot`]).
    Demo,
    /// A path [`crate::volume::open()`] reads: a volume file or a DICOM series.
    Path(PathBuf),
    /// One series of a DICOM folder that holds several.
    Series {
        /// The folder.
        folder: PathBuf,
        /// Its SeriesInstanceUID.
        series_uid: String,
        /// What a person reads about it (description, modality, images); not part of its
        /// identity, and empty when the source comes from a key.
        label: String,
    },
}

/// Sources are the same when they read the same voxels: a series' label does not count.
impl PartialEq for VolumeSource {
    fn eq(&self, other: &VolumeSource) -> bool {
        match (self, other) {
            (VolumeSource::Demo, VolumeSource::Demo) => true,
            (VolumeSource::Path(a), VolumeSource::Path(b)) => a == b,
            (
                VolumeSource::Series { folder: folder_a, series_uid: uid_a, .. },
                VolumeSource::Series { folder: folder_b, series_uid: uid_b, .. },
            ) => folder_a == folder_b && uid_a == uid_b,
            _ => false,
        }
    }
}

impl Eq for VolumeSource {}

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

    /// What autosave writes: "demo", the path, or a folder's path, [`SERIES_MARK`] and a
    /// series' UID.
    pub fn key(&self) -> String {
        match self {
            VolumeSource::Demo => DEMO_VOLUME.to_string(),
            VolumeSource::Path(path) => path.display().to_string(),
            VolumeSource::Series { folder, series_uid, .. } => format!("{}{SERIES_MARK}{series_uid}", folder.display()),
        }
    }

    /// The source an autosave's key names. A key with [`SERIES_MARK`] followed by a UID is a
    /// series of the folder before it, unless a file of that whole name exists.
    pub fn from_key(key: &str) -> VolumeSource {
        if let Some((folder, series_uid)) = key.rsplit_once(SERIES_MARK)
            && is_uid(series_uid)
            && !Path::new(key).exists()
        {
            return VolumeSource::Series {
                folder: PathBuf::from(folder),
                series_uid: series_uid.to_string(),
                label: String::new(),
            };
        }
        VolumeSource::from_path(Path::new(key))
    }

    /// The file or folder the volume is read from; `None` for the demo.
    pub fn path(&self) -> Option<&Path> {
        match self {
            VolumeSource::Demo => None,
            VolumeSource::Path(path) => Some(path),
            VolumeSource::Series { folder, .. } => Some(folder),
        }
    }

    /// The name a person reads: the demo's description or the file name.
    pub fn name(&self) -> String {
        match self {
            VolumeSource::Demo => "Demo: CT foot phantom".to_string(),
            VolumeSource::Path(path) => path
                .file_name()
                .map(|name| name.to_string_lossy().into_owned())
                .unwrap_or_else(|| path.display().to_string()),
            VolumeSource::Series { folder, series_uid, label } => {
                let folder = VolumeSource::Path(folder.clone()).name();
                if label.is_empty() {
                    format!("{folder}: series {}", uid_tail(series_uid))
                } else {
                    format!("{folder}: {label}")
                }
            }
        }
    }

    /// The volume: the demo phantom generated, or the file opened with `options`.
    pub fn open(&self, options: &OpenOptions) -> Result<Volume, VolumeError> {
        match self {
            VolumeSource::Demo => Ok(super::demo_foot().volume),
            VolumeSource::Path(path) => crate::volume::open(path, options),
            VolumeSource::Series { folder, series_uid, .. } => {
                let mut options = options.clone();
                options.dicom.series_uid = Some(series_uid.clone());
                crate::volume::open(folder, &options)
            }
        }
    }
}

/// A DICOM UID: digits and dots, at most 64 characters (PS3.5 §9.1).
fn is_uid(text: &str) -> bool {
    !text.is_empty() && text.len() <= 64 && text.bytes().all(|b| b.is_ascii_digit() || b == b'.')
}

/// The last few digits of a UID, enough to tell a folder's series apart on a card.
pub fn uid_tail(series_uid: &str) -> &str {
    let start = series_uid.len().saturating_sub(6);
    series_uid.get(start..).unwrap_or(series_uid)
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

    #[test]
    fn a_series_of_a_folder_round_trips_through_its_key_and_is_named_for_people() {
        let series = VolumeSource::Series {
            folder: "/data/hospital".into(),
            series_uid: "1.2.840.113619.2.55".into(),
            label: "STD BRAIN 5MM (CT, 28 images)".into(),
        };
        assert_eq!(series.key(), "/data/hospital#series=1.2.840.113619.2.55");
        let back = VolumeSource::from_key(&series.key());
        assert_eq!(back, series, "the label is not part of the identity");
        assert_eq!(series.name(), "hospital: STD BRAIN 5MM (CT, 28 images)");
        assert_eq!(back.name(), "hospital: series 619.2.55".replace("619.2.55", uid_tail("1.2.840.113619.2.55")));
        // Not a UID after the mark: an ordinary path.
        assert_eq!(VolumeSource::from_key("/data/a#series=x y"), VolumeSource::Path("/data/a#series=x y".into()));
        assert_ne!(series, VolumeSource::Path("/data/hospital".into()));
    }
}
