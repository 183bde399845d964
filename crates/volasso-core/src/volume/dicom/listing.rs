//! What a DICOM folder holds, without reading pixel data: the image series a picker offers
//! ([`list_series`]), and the identity of one received file ([`read_identity`]).
//!
//! A kiosk screen may be public: who the patient is (name, ID, birth date, sex) and the study's
//! date are read only when the caller asks ([`PatientShown::Shown`], a bedside's clinical
//! mode), and are never logged here.
//!
//! Never: decodes pixels, or decides which series to open (the caller passes the chosen
//! SeriesInstanceUID to [`super::DicomOptions::series_uid`]).

use super::bounds::Scope;
use super::header::{self, FileKind};
use super::series::{self, FoundImages};
use crate::volume::VolumeError;
use crate::volume::limits::ReadLimits;
use dicom_dictionary_std::tags;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Whether a listing carries who the patient is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PatientShown {
    /// The default: a public screen shows no patient data.
    #[default]
    Hidden,
    /// Configured for a private screen.
    Shown,
}

/// Who the patient is, and when the study was, as the files hold them (each empty when absent).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct PatientIdentity {
    /// PatientName (0010,0010), a DICOM person name (`FAMILY^GIVEN^MIDDLE^PREFIX^SUFFIX`).
    pub name: String,
    /// PatientID (0010,0020).
    pub id: String,
    /// PatientBirthDate (0010,0030), `YYYYMMDD`.
    pub birth_date: String,
    /// PatientSex (0010,0040): `M`, `F` or `O`.
    pub sex: String,
    /// StudyDate (0008,0020), `YYYYMMDD`.
    pub study_date: String,
}

/// One image series under a path, as a series picker shows it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SeriesSummary {
    /// SeriesInstanceUID: pass it to [`super::DicomOptions::series_uid`] to open this series.
    /// Empty for images without one (they form one series).
    pub series_uid: String,
    /// SeriesDescription, empty when absent.
    pub description: String,
    /// Modality (CT, MR, ...), empty when absent.
    pub modality: String,
    /// Images in the series: files, or frames of multi-frame files.
    pub images: usize,
    /// Why this reader cannot open the series (a colour image, a transfer syntax without a
    /// decoder), or `None` when it can try.
    pub unreadable: Option<String>,
    /// Only with [`PatientShown::Shown`].
    pub patient: Option<PatientIdentity>,
}

/// The image series under `path` (a folder, a DICOMDIR or one file), readable ones first,
/// each group in SeriesDescription then UID order. DICOM files that cannot be read at all are
/// not listed (which series they belong to is unknowable); opening a series reports them.
pub fn list_series(path: &Path, patient: PatientShown, limits: &ReadLimits) -> Result<Vec<SeriesSummary>, VolumeError> {
    let source = series::list_source(path, limits)?;
    let found = match &source.folder {
        Some(folder) => series::read_folder_headers(&source.files, folder, path, limits)?,
        None => match source.files.first().map(|file| header::read_header(file, limits)).transpose()? {
            Some(FileKind::Image(headers)) => {
                FoundImages { readable: headers, unsupported: Vec::new(), unreadable: Vec::new() }
            }
            Some(FileKind::Unsupported { series_uid, series_description, error }) => FoundImages {
                readable: Vec::new(),
                unsupported: vec![(series_uid, series_description, error)],
                unreadable: Vec::new(),
            },
            Some(FileKind::NotImage) | None => return Ok(Vec::new()),
        },
    };
    // (summary, a file of the series to read the patient from)
    let mut listed: BTreeMap<(bool, String, String), (SeriesSummary, PathBuf)> = BTreeMap::new();
    for header in found.readable {
        let key = (false, header.series_description.clone(), header.series_uid.clone());
        listed
            .entry(key)
            .or_insert_with(|| {
                let summary = SeriesSummary {
                    series_uid: header.series_uid.clone(),
                    description: header.series_description.clone(),
                    modality: header.modality.clone(),
                    images: 0,
                    unreadable: None,
                    patient: None,
                };
                (summary, header.path.clone())
            })
            .0
            .images += 1;
    }
    for (series_uid, description, error) in found.unsupported {
        let readable_key = (false, description.clone(), series_uid.clone());
        if let Some((summary, _)) = listed.get_mut(&readable_key) {
            // A series with one file this reader cannot decode cannot be read as a whole.
            summary.images += 1;
            summary.unreadable.get_or_insert_with(|| error.to_string());
            continue;
        }
        let path = error_path(&error);
        let key = (true, description.clone(), series_uid.clone());
        let entry = listed.entry(key).or_insert_with(|| {
            let summary = SeriesSummary {
                series_uid,
                description,
                modality: String::new(),
                images: 0,
                unreadable: Some(error.to_string()),
                patient: None,
            };
            (summary, path)
        });
        entry.0.images += 1;
    }
    let mut summaries = Vec::with_capacity(listed.len());
    for (_, (mut summary, file)) in listed {
        if summary.unreadable.is_some() || patient == PatientShown::Shown {
            let identity = read_identity(&file, limits).ok();
            if summary.modality.is_empty() {
                summary.modality = identity.as_ref().map(|identity| identity.modality.clone()).unwrap_or_default();
            }
            if patient == PatientShown::Shown {
                summary.patient = identity.map(|identity| identity.patient);
            }
        }
        summaries.push(summary);
    }
    Ok(summaries)
}

/// The path an error names (the file it came from), or an empty path.
fn error_path(error: &VolumeError) -> PathBuf {
    match error {
        VolumeError::Unsupported { path, .. } | VolumeError::Dicom { path, .. } => path.clone(),
        _ => PathBuf::new(),
    }
}

/// What identifies one DICOM instance: its series, itself, its SOP class and modality, and
/// its patient (never logged).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InstanceIdentity {
    /// SeriesInstanceUID (0020,000E), empty when absent.
    pub series_uid: String,
    /// SOPInstanceUID (0008,0018): this instance's own UID.
    pub sop_instance_uid: String,
    /// SOPClassUID (0008,0016): what kind of object it is (CT image, MR image, ...).
    pub sop_class_uid: String,
    /// Modality (0008,0060), such as `CT` or `MR`; empty when absent.
    pub modality: String,
    /// SeriesDescription (0008,103E), empty when absent.
    pub series_description: String,
    /// The patient's name and ID (never logged).
    pub patient: PatientIdentity,
}

/// The identity of the DICOM file at `path`, read from its attributes before PixelData (their
/// lengths checked first).
pub fn read_identity(path: &Path, limits: &ReadLimits) -> Result<InstanceIdentity, VolumeError> {
    let object = super::unknown_vr::read_object(path, Scope::Header, limits)?;
    Ok(InstanceIdentity {
        series_uid: header::text(&object, tags::SERIES_INSTANCE_UID),
        sop_instance_uid: header::text(&object, tags::SOP_INSTANCE_UID),
        sop_class_uid: header::text(&object, tags::SOP_CLASS_UID),
        modality: header::text(&object, tags::MODALITY),
        series_description: header::text(&object, tags::SERIES_DESCRIPTION),
        patient: PatientIdentity {
            name: header::text(&object, tags::PATIENT_NAME),
            id: header::text(&object, tags::PATIENT_ID),
            birth_date: header::text(&object, tags::PATIENT_BIRTH_DATE),
            sex: header::text(&object, tags::PATIENT_SEX),
            study_date: header::text(&object, tags::STUDY_DATE),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::super::synthetic::SyntheticSlice;
    use super::*;

    #[test]
    fn a_folder_of_three_series_lists_each_with_its_count_and_no_patient_unless_asked() {
        let folder = tempfile::tempdir().unwrap();
        for k in 0..3 {
            SyntheticSlice::axial("1.2.3", &format!("1.2.3.{k}"), [2, 2], [0.0, 0.0, k as f64], |_, _| 1)
                .write(&folder.path().join(format!("a{k}.dcm")));
        }
        for k in 0..2 {
            SyntheticSlice::axial("4.5.6", &format!("4.5.6.{k}"), [2, 2], [0.0, 0.0, k as f64], |_, _| 1)
                .write(&folder.path().join(format!("b{k}.dcm")));
        }
        let mut colour = SyntheticSlice::axial("7.8.9", "7.8.9.0", [2, 2], [0.0; 3], |_, _| 0);
        colour.samples_per_pixel = 3;
        colour.write(&folder.path().join("colour.dcm"));
        let limits = ReadLimits::default();
        let listed = list_series(folder.path(), PatientShown::Hidden, &limits).unwrap();
        let brief: Vec<(&str, usize, bool)> =
            listed.iter().map(|s| (s.series_uid.as_str(), s.images, s.unreadable.is_some())).collect();
        assert_eq!(brief, [("1.2.3", 3, false), ("4.5.6", 2, false), ("7.8.9", 1, true)]);
        assert!(listed.iter().all(|s| s.patient.is_none() && s.modality == "CT" && s.description == "synthetic"));
        assert!(listed[2].unreadable.as_deref().unwrap().contains("colour"), "{:?}", listed[2].unreadable);
        let shown = list_series(folder.path(), PatientShown::Shown, &limits).unwrap();
        assert!(shown.iter().all(|s| s.patient.is_some()));
        let identity = read_identity(&folder.path().join("b1.dcm"), &limits).unwrap();
        assert_eq!((identity.series_uid.as_str(), identity.sop_instance_uid.as_str()), ("4.5.6", "4.5.6.1"));
        assert_eq!(identity.sop_class_uid, "1.2.840.10008.5.1.4.1.1.2");
    }
}
