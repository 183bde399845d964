//! Results back as DICOM (`volasso export`, `interfaces.md`; `docs/conformance.md`): a label
//! volume of a DICOM series becomes a binary DICOM Segmentation (`seg.rs`, PS3.3 A.51) and a
//! rendered picture a Secondary Capture image (`sc.rs`, PS3.3 A.8.1), each in a new series of
//! the source's study, built with dicom-rs's object model (no hand-written encoding).
//!
//! The source series is read as the volume reader reads it ([`SourceSeries::read`]: the same
//! listing, series choice and slice order), so frame `z` of the Segmentation is exactly slice
//! `z` of the label volume, and the pixel at row `y`, column `x` is voxel `(x, y, z)`. Only
//! series the reader stacks as they are, one file per slice, can be exported: a resampled or
//! multi-frame series has no source slice for each label slice.
//!
//! Never: exports labels of a volume that did not come from DICOM, labels whose dimensions
//! differ from the series', or labels whose class table does not match them; changes the
//! source files; writes an object partly (the caller stages each file whole,
//! [`volasso_core::atomic_file`]).

mod sc;
mod seg;

pub use sc::secondary_capture;
pub use seg::{Segment, segmentation};

use dicom_core::value::DataSetSequence;
use dicom_core::{DataElement, PrimitiveValue, Tag, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileDicomObject, FileMetaTableBuilder, InMemDicomObject};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use volasso_core::volume::VolumeError;
use volasso_core::volume::dicom::{self, DicomOptions, Resample};
use volasso_core::volume::limits::ReadLimits;

/// Explicit VR Little Endian: the transfer syntax of every object written here.
pub const EXPLICIT_VR_LITTLE_ENDIAN: &str = "1.2.840.10008.1.2.1";
/// Segmentation Storage.
pub const SEGMENTATION_STORAGE: &str = "1.2.840.10008.5.1.4.1.1.66.4";
/// Secondary Capture Image Storage.
pub const SECONDARY_CAPTURE_STORAGE: &str = "1.2.840.10008.5.1.4.1.1.7";

/// Why an export cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The source is a NRRD, raw or other file without a study to join.
    #[error("only a DICOM series can be exported as DICOM (it has a study to join); this is not one: {}", path.display())]
    NotDicom {
        /// The volume given.
        path: PathBuf,
    },
    /// The series cannot be read as the kiosk reads it.
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// The series is not one file per slice (multi-frame), so label slices have no source image.
    #[error(
        "the series has {files} files for {slices} slices (a multi-frame image): its label slices cannot be matched to source images, in {}",
        path.display()
    )]
    NotOneFilePerSlice {
        /// Files in the series.
        files: usize,
        /// Slices of its volume.
        slices: usize,
        /// The series.
        path: PathBuf,
    },
    /// A source image lacks an attribute the objects need.
    #[error("the source image has no {attribute}, which the exported objects need: {}", path.display())]
    SourceAttribute {
        /// The attribute's keyword.
        attribute: &'static str,
        /// The image file.
        path: PathBuf,
    },
    /// The label volume is not of the kind `classify` writes.
    #[error("the label volume is {found}, not uint8: {}", path.display())]
    LabelType {
        /// The labels' voxel type.
        found: &'static str,
        /// The label volume.
        path: PathBuf,
    },
    /// The labels were not computed on this series.
    #[error(
        "the label volume is {}x{}x{} voxels but the series is {}x{}x{}: they do not belong together, {}",
        labels[0], labels[1], labels[2], series[0], series[1], series[2], path.display()
    )]
    LabelDims {
        /// The labels' dimensions.
        labels: [usize; 3],
        /// The series' volume's dimensions.
        series: [usize; 3],
        /// The label volume.
        path: PathBuf,
    },
    /// The class table beside the labels does not describe them.
    #[error("the class table does not match the labels: {problem}, {}", path.display())]
    ClassTable {
        /// What does not match.
        problem: String,
        /// The class table.
        path: PathBuf,
    },
    /// The picture for the Secondary Capture cannot be read.
    #[error("cannot read the picture: {problem}, {}", path.display())]
    Picture {
        /// The decoder's complaint.
        problem: String,
        /// The picture.
        path: PathBuf,
    },
    /// dicom-rs refused to build an object (a value out of its VR's bounds).
    #[error("cannot build the {what}: {problem}")]
    Build {
        /// Which object.
        what: &'static str,
        /// What dicom-rs or the sizes refused.
        problem: String,
    },
}

/// A source slice: the file it lies in and what the exported objects reference of it.
#[derive(Clone, Debug)]
pub struct SourceImage {
    /// The file.
    pub path: PathBuf,
    /// Its SOPClassUID.
    pub sop_class_uid: String,
    /// Its SOPInstanceUID.
    pub sop_instance_uid: String,
    /// ImagePositionPatient, as written in the file.
    pub position: Vec<String>,
}

/// A DICOM series as the volume reader stacks it (see the module doc).
#[derive(Debug)]
pub struct SourceSeries {
    /// The volume's voxels along x (columns), y (rows), z (slices).
    pub dims: [usize; 3],
    /// Slice `z` of the volume is `images[z]`.
    pub images: Vec<SourceImage>,
    /// The SeriesInstanceUID.
    pub series_uid: String,
    /// The first slice's header (patient, study, geometry attributes are copied from it).
    pub first: InMemDicomObject,
    /// The distance between slice centres along the normal, mm.
    pub slice_spacing_mm: f64,
}

impl SourceSeries {
    /// Reads the headers of the series at `path` (a folder, DICOMDIR or file; `series_uid`
    /// picks one of several) in the reader's slice order.
    pub fn read(path: &Path, series_uid: Option<&str>) -> Result<SourceSeries, ExportError> {
        if !dicom::looks_like_dicom(path) {
            return Err(ExportError::NotDicom { path: path.to_path_buf() });
        }
        let limits = ReadLimits::default();
        let source = dicom::list_source(path, &limits)?;
        let options = DicomOptions {
            series_uid: series_uid.map(str::to_string),
            resample: Resample::Refuse,
            ..DicomOptions::default()
        };
        let check = dicom::check_source(path, &source, &options, &limits)?;
        if check.files.len() != check.dims[2] {
            return Err(ExportError::NotOneFilePerSlice {
                files: check.files.len(),
                slices: check.dims[2],
                path: path.to_path_buf(),
            });
        }
        let mut images = Vec::with_capacity(check.files.len());
        let mut first = None;
        for file in &check.files {
            let object = dicom_object::OpenFileOptions::new()
                .read_until(tags::PIXEL_DATA)
                .open_file(file)
                .map_err(|error| VolumeError::Dicom { problem: error.to_string(), path: file.clone() })?;
            let text = |tag: Tag, attribute: &'static str| {
                object
                    .element(tag)
                    .ok()
                    .and_then(|element| element.to_str().ok())
                    .map(|value| value.trim_end_matches(['\0', ' ']).to_string())
                    .filter(|value| !value.is_empty())
                    .ok_or_else(|| ExportError::SourceAttribute { attribute, path: file.clone() })
            };
            let position = text(tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient")?;
            images.push(SourceImage {
                path: file.clone(),
                sop_class_uid: text(tags::SOP_CLASS_UID, "SOPClassUID")?,
                sop_instance_uid: text(tags::SOP_INSTANCE_UID, "SOPInstanceUID")?,
                position: position.split('\\').map(|part| part.trim().to_string()).collect(),
            });
            for (tag, attribute) in [
                (tags::FRAME_OF_REFERENCE_UID, "FrameOfReferenceUID"),
                (tags::STUDY_INSTANCE_UID, "StudyInstanceUID"),
                (tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient"),
                (tags::PIXEL_SPACING, "PixelSpacing"),
            ] {
                text(tag, attribute)?;
            }
            if first.is_none() {
                first = Some(object.into_inner());
            }
        }
        let first = first.ok_or_else(|| ExportError::NotOneFilePerSlice {
            files: 0,
            slices: check.dims[2],
            path: path.to_path_buf(),
        })?;
        let slice_spacing_mm = slice_spacing(&images).unwrap_or_else(|| {
            first
                .element(tags::SLICE_THICKNESS)
                .ok()
                .and_then(|element| element.to_float64().ok())
                .filter(|value| value.is_finite() && *value > 0.0)
                .unwrap_or(1.0)
        });
        Ok(SourceSeries { dims: check.dims, images, series_uid: check.series_uid, first, slice_spacing_mm })
    }

    /// The first slice's value of `tag` as text, empty when absent.
    pub fn text(&self, tag: Tag) -> String {
        self.first
            .element(tag)
            .ok()
            .and_then(|element| element.to_str().ok())
            .map(|value| value.trim_end_matches(['\0', ' ']).to_string())
            .unwrap_or_default()
    }
}

/// The mean distance between the first and last slice positions, per gap.
fn slice_spacing(images: &[SourceImage]) -> Option<f64> {
    let point = |image: &SourceImage| -> Option<[f64; 3]> {
        let values: Vec<f64> = image.position.iter().filter_map(|part| part.parse().ok()).collect();
        <[f64; 3]>::try_from(values).ok()
    };
    let (first, last) = (point(images.first()?)?, point(images.last()?)?);
    let gaps = images.len().checked_sub(1).filter(|&gaps| gaps > 0)? as f64;
    let distance = (0..3).map(|axis| (last[axis] - first[axis]).powi(2)).sum::<f64>().sqrt();
    (distance > 0.0).then_some(distance / gaps)
}

/// A new UID under the UUID-derived root `2.25` (PS3.5 B.2): 128 bits from the clock, the
/// process, a counter and `purpose`, hashed.
pub fn new_uid(purpose: &str) -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let nanoseconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
    let mut hasher = Sha256::new();
    hasher.update(nanoseconds.to_le_bytes());
    hasher.update(std::process::id().to_le_bytes());
    hasher.update(COUNTER.fetch_add(1, Ordering::Relaxed).to_le_bytes());
    hasher.update(purpose.as_bytes());
    let digest = hasher.finalize();
    let mut bytes = [0u8; 16];
    bytes.copy_from_slice(&digest[..16]);
    // A version-4-like UUID's variant and version bits are not needed under 2.25; the value
    // is any 128-bit number without leading zeros in decimal.
    format!("2.25.{}", u128::from_be_bytes(bytes))
}

/// A decimal string (DS) of at most 16 characters.
pub(crate) fn decimal(value: f64) -> String {
    let plain = format!("{value}");
    if plain.len() <= 16 {
        return plain;
    }
    for precision in (0..=10).rev() {
        let text = format!("{value:.precision$}");
        if text.len() <= 16 {
            return text;
        }
    }
    format!("{value:.3e}")
}

/// Today's date (DA) and time (TM) in UTC.
pub(crate) fn date_time_now() -> (String, String) {
    let seconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let of_day = seconds % 86_400;
    let [year, month, day] = volasso_core::calendar::civil_from_days((seconds / 86_400) as i64);
    (format!("{year:04}{month:02}{day:02}"), format!("{:02}{:02}{:02}", of_day / 3600, of_day % 3600 / 60, of_day % 60))
}

/// A text element.
pub(crate) fn text(tag: Tag, vr: VR, value: &str) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, vr, PrimitiveValue::from(value))
}

/// A multi-valued text element (DS, CS, IS...).
pub(crate) fn texts(tag: Tag, vr: VR, values: &[String]) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, vr, PrimitiveValue::Strs(values.iter().cloned().collect()))
}

/// An unsigned short element.
pub(crate) fn ushort(tag: Tag, value: u16) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, VR::US, PrimitiveValue::from(value))
}

/// A sequence element of `items`.
pub(crate) fn sequence(tag: Tag, items: Vec<InMemDicomObject>) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, VR::SQ, DataSetSequence::from(items))
}

/// A code sequence item: (value, scheme, meaning).
pub(crate) fn code(value: &str, scheme: &str, meaning: &str) -> InMemDicomObject {
    InMemDicomObject::from_element_iter([
        text(tags::CODE_VALUE, VR::SH, value),
        text(tags::CODING_SCHEME_DESIGNATOR, VR::SH, scheme),
        text(tags::CODE_MEANING, VR::LO, meaning),
    ])
}

/// Copies the Patient, General Study, Frame of Reference and character set attributes of the
/// source series into `object`: the new series joins the source's study. Type 2 attributes
/// absent from the source are written empty.
pub(crate) fn copy_patient_and_study(source: &SourceSeries, object: &mut InMemDicomObject, frame_of_reference: bool) {
    let copied: &[(Tag, VR)] = &[
        (tags::SPECIFIC_CHARACTER_SET, VR::CS),
        (tags::PATIENT_NAME, VR::PN),
        (tags::PATIENT_ID, VR::LO),
        (tags::PATIENT_BIRTH_DATE, VR::DA),
        (tags::PATIENT_SEX, VR::CS),
        (tags::STUDY_INSTANCE_UID, VR::UI),
        (tags::STUDY_DATE, VR::DA),
        (tags::STUDY_TIME, VR::TM),
        (tags::REFERRING_PHYSICIAN_NAME, VR::PN),
        (tags::STUDY_ID, VR::SH),
        (tags::ACCESSION_NUMBER, VR::SH),
        (tags::STUDY_DESCRIPTION, VR::LO),
    ];
    let type_two = [
        tags::PATIENT_NAME,
        tags::PATIENT_ID,
        tags::PATIENT_BIRTH_DATE,
        tags::PATIENT_SEX,
        tags::STUDY_DATE,
        tags::STUDY_TIME,
        tags::REFERRING_PHYSICIAN_NAME,
        tags::STUDY_ID,
        tags::ACCESSION_NUMBER,
    ];
    for &(tag, vr) in copied {
        match source.first.element(tag) {
            Ok(element) => {
                object.put(element.clone());
            }
            Err(_) if type_two.contains(&tag) => {
                object.put(DataElement::new(tag, vr, PrimitiveValue::Empty));
            }
            Err(_) => {}
        }
    }
    if frame_of_reference {
        object.put(text(tags::FRAME_OF_REFERENCE_UID, VR::UI, &source.text(tags::FRAME_OF_REFERENCE_UID)));
        object.put(text(tags::POSITION_REFERENCE_INDICATOR, VR::LO, &source.text(tags::POSITION_REFERENCE_INDICATOR)));
    }
}

/// The General Equipment and SOP Common attributes every object written here carries.
pub(crate) fn put_equipment(object: &mut InMemDicomObject) {
    object.put(text(tags::MANUFACTURER, VR::LO, "volasso"));
    object.put(text(tags::MANUFACTURER_MODEL_NAME, VR::LO, "volasso"));
    object.put(text(tags::DEVICE_SERIAL_NUMBER, VR::LO, "1"));
    object.put(text(tags::SOFTWARE_VERSIONS, VR::LO, env!("CARGO_PKG_VERSION")));
}

/// `object` with its file meta (Explicit VR Little Endian; the implementation class UID and
/// version name are dicom-rs's, as in every file and association of volasso).
pub(crate) fn with_meta(
    object: InMemDicomObject,
    what: &'static str,
) -> Result<FileDicomObject<InMemDicomObject>, ExportError> {
    object
        .with_meta(FileMetaTableBuilder::new().transfer_syntax(EXPLICIT_VR_LITTLE_ENDIAN))
        .map_err(|error| ExportError::Build { what, problem: error.to_string() })
}

/// Writes `object` as a DICOM file (preamble, meta, data set) to `writer`.
pub fn write_object(
    object: &FileDicomObject<InMemDicomObject>,
    writer: &mut impl std::io::Write,
) -> std::io::Result<()> {
    object.write_all(writer).map_err(std::io::Error::other)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_strings_fit_sixteen_characters() {
        for value in [0.451171875, -115.5, 696.21, 1.0 / 3.0, -123456.789012345, 5.0, 1e-9] {
            let text = decimal(value);
            assert!(text.len() <= 16, "{text}");
            let back: f64 = text.parse().unwrap();
            assert!((back - value).abs() <= value.abs() * 1e-9 + 1e-9, "{value} -> {text}");
        }
    }

    #[test]
    fn uids_are_new_and_well_formed() {
        let (a, b) = (new_uid("x"), new_uid("x"));
        assert_ne!(a, b);
        for uid in [a, b] {
            assert!(uid.len() <= 64 && uid.starts_with("2.25."), "{uid}");
            assert!(uid[5..].bytes().all(|c| c.is_ascii_digit()) && !uid[5..].starts_with('0'), "{uid}");
        }
    }

    #[test]
    fn dates_are_civil() {
        let (date, time) = date_time_now();
        assert_eq!(date.len(), 8);
        assert_eq!(time.len(), 6);
        assert!(date.as_str() > "20240101", "{date}");
    }
}
