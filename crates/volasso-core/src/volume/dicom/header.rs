//! One DICOM file's header: the attributes that put an image into a series and into space.
//! The file's element lengths are checked against its size before it is parsed
//! ([`super::bounds`]).
//!
//! [`read_header`] parses a file up to (not including) its PixelData and returns a
//! [`SliceHeader`], or [`FileKind::NotImage`] for DICOM files that hold no image (a DICOMDIR,
//! a structured report, a presentation state). Everything a later stage relies on is checked
//! here once: one sample per pixel, 8 or 16 allocated bits, a transfer syntax whose pixel data
//! dicom-rs's codec registry decodes (native, deflated, JPEG, JPEG-LS, JPEG 2000, RLE; see
//! [`readable_transfer_syntax`]), a finite rescale or a Modality LUT it can apply
//! ([`super::modality_lut`]), unit orientation cosines. A PixelSpacing of 0 counts as absent.
//! An enhanced multi-frame image gives one header per frame ([`super::frames`]), also one
//! without functional groups (its frames then have no positions). Attributes stored as UN are
//! read in their dictionary VR first ([`super::unknown_vr`]).
//!
//! Never: reads pixel data (that is [`super::pixels`]) or compares files with each other
//! (that is [`super::geometry`]).

use super::bounds::Scope;
use super::modality_lut::ModalityLut;
use crate::volume::limits::ReadLimits;
use crate::volume::{ValueScale, VolumeError};
use dicom_core::Tag;
use dicom_dictionary_std::tags;
use dicom_encoding::transfer_syntax::TransferSyntaxIndex;
use dicom_object::{DefaultDicomObject, InMemDicomObject};
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Media Storage SOP Class UID of a DICOMDIR (Media Storage Directory Storage).
pub(super) const MEDIA_STORAGE_DIRECTORY_UID: &str = "1.2.840.10008.1.3.10";

/// Transfer syntaxes whose PixelData is stored uncompressed (native).
const NATIVE_TRANSFER_SYNTAXES: [&str; 3] = [
    "1.2.840.10008.1.2",   // Implicit VR Little Endian
    "1.2.840.10008.1.2.1", // Explicit VR Little Endian
    "1.2.840.10008.1.2.2", // Explicit VR Big Endian (retired)
];

/// True when this reader decodes the pixel data of `uid`: a native syntax, Deflated Explicit VR
/// Little Endian (inflated by the `deflated` module), or a syntax whose decoder dicom-rs's
/// registry holds in this build (JPEG baseline, extended and lossless, JPEG-LS, JPEG 2000, RLE).
pub fn readable_transfer_syntax(uid: &str) -> bool {
    let uid = uid.trim_end_matches(['\0', ' ']);
    NATIVE_TRANSFER_SYNTAXES.contains(&uid)
        || uid == super::deflated::DEFLATED_EXPLICIT_LITTLE
        || TransferSyntaxRegistry.get(uid).is_some_and(|syntax| syntax.can_decode_all())
}

/// How stored pixel samples are laid out (Image Pixel module).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct PixelFormat {
    /// 8 or 16.
    pub bits_allocated: u16,
    /// Significant low bits of each sample; the rest may hold overlays and are masked off.
    pub bits_stored: u16,
    /// PixelRepresentation 1: two's complement within `bits_stored`.
    pub signed: bool,
}

/// What the series assembly needs to know about one image file.
#[derive(Clone, Debug)]
pub(super) struct SliceHeader {
    pub path: PathBuf,
    /// Empty when the file has none (then it forms a series of its own kind with other such files).
    pub series_uid: String,
    pub series_description: String,
    /// Modality (CT, MR, ...), empty when absent.
    pub modality: String,
    pub sop_instance_uid: String,
    /// Which frame of the file this is (0 for a single-frame file).
    pub frame: u32,
    /// NumberOfFrames of the file (1 for a single-frame file).
    pub frames_in_file: u32,
    pub rows: usize,
    pub columns: usize,
    /// DICOM order: spacing between rows (along y), then between columns (along x).
    pub pixel_spacing_mm: Option<[f64; 2]>,
    /// The PixelSpacing (or ImagerPixelSpacing) that was given as 0 and so taken as absent.
    pub zero_pixel_spacing: Option<[f64; 2]>,
    /// ImagePositionPatient: centre of the first transmitted pixel.
    pub position_mm: Option<[f64; 3]>,
    /// ImageOrientationPatient: row direction cosines, then column direction cosines, normalised.
    pub orientation: Option<[f64; 6]>,
    /// SpacingBetweenSlices, else SliceThickness: only used for a single slice.
    pub slice_thickness_mm: Option<f64>,
    pub pixel_format: PixelFormat,
    pub rescale: ValueScale,
    /// The Modality LUT that replaces the rescale, where the file has one.
    pub modality_lut: Option<Arc<ModalityLut>>,
}

/// Storage SOP classes that always carry Rows/Columns (CR, DX, CT, MR, NM, US, secondary
/// capture, XA, PET): such a file without them is damaged, not a report.
const IMAGE_STORAGE_CLASSES: [&str; 11] = [
    "1.2.840.10008.5.1.4.1.1.1",
    "1.2.840.10008.5.1.4.1.1.1.1",
    "1.2.840.10008.5.1.4.1.1.2",
    "1.2.840.10008.5.1.4.1.1.2.1",
    "1.2.840.10008.5.1.4.1.1.4",
    "1.2.840.10008.5.1.4.1.1.4.1",
    "1.2.840.10008.5.1.4.1.1.20",
    "1.2.840.10008.5.1.4.1.1.6.1",
    "1.2.840.10008.5.1.4.1.1.7",
    "1.2.840.10008.5.1.4.1.1.12.1",
    "1.2.840.10008.5.1.4.1.1.128",
];

/// Enhanced (and legacy-converted enhanced) CT and MR storage: every frame of such a file is a
/// slice of one volume, with or without functional groups to place it.
const ENHANCED_VOLUME_CLASSES: [&str; 4] = [
    "1.2.840.10008.5.1.4.1.1.2.1",
    "1.2.840.10008.5.1.4.1.1.2.2",
    "1.2.840.10008.5.1.4.1.1.4.1",
    "1.2.840.10008.5.1.4.1.1.4.4",
];

/// The result of looking at one DICOM file.
#[derive(Debug)]
pub(super) enum FileKind {
    /// One header per frame (one for a single-frame file), in frame order.
    Image(Vec<SliceHeader>),
    /// A well-formed image this reader cannot turn into voxels (colour, a transfer syntax
    /// without a decoder, multi-frame without per-frame positions, odd bit layout, a Modality
    /// LUT it cannot apply). Its series is skipped with a warning when another series can be
    /// read, and `error` is returned when it is the one asked for.
    Unsupported { series_uid: String, series_description: String, error: VolumeError },
    /// A valid DICOM file without an image (DICOMDIR, report): skipped quietly.
    NotImage,
}

/// Opens `path` (which must carry the DICM preamble and a file meta group) and reads its header,
/// its element lengths checked first ([`bounds`]).
pub(super) fn read_header(path: &Path, limits: &ReadLimits) -> Result<FileKind, VolumeError> {
    let object = super::unknown_vr::read_object(path, Scope::Header, limits)?;
    if object.meta().media_storage_sop_class_uid() == MEDIA_STORAGE_DIRECTORY_UID {
        return Ok(FileKind::NotImage);
    }
    let (Some(rows), Some(columns)) =
        (unsigned(&object, tags::ROWS, "Rows", path)?, unsigned(&object, tags::COLUMNS, "Columns", path)?)
    else {
        let sop_class = object.meta().media_storage_sop_class_uid();
        if IMAGE_STORAGE_CLASSES.contains(&sop_class) {
            // dicom-rs ends a data set quietly at some truncation points.
            return Err(VolumeError::Dicom {
                problem: format!(
                    "image storage file (SOP class {sop_class}) without Rows/Columns: truncated or damaged"
                ),
                path: path.to_path_buf(),
            });
        }
        return Ok(FileKind::NotImage);
    };
    if rows == 0 || columns == 0 || rows > u32::from(u16::MAX) || columns > u32::from(u16::MAX) {
        return Err(VolumeError::BadDimensions {
            dims: [u64::from(columns), u64::from(rows), 1],
            problem: "Rows and Columns must be 1..65535",
            path: path.to_path_buf(),
        });
    }
    let series_uid = text(&object, tags::SERIES_INSTANCE_UID);
    let series_description = text(&object, tags::SERIES_DESCRIPTION);
    let supported = check_transfer_syntax(object.meta().transfer_syntax(), path)
        .and_then(|()| check_grey(&object, path))
        .and_then(|()| pixel_format(&object, path));
    let pixel_format = match supported {
        Ok(pixel_format) => pixel_format,
        Err(error) => {
            return Ok(FileKind::Unsupported { series_uid, series_description, error });
        }
    };
    let frames_in_file = match unsigned(&object, tags::NUMBER_OF_FRAMES, "NumberOfFrames", path)? {
        None => 1,
        Some(0) => return Err(VolumeError::header("NumberOfFrames", "is 0", path)),
        Some(frames) => frames,
    };
    let plane = PlaneAttributes::read(&object, path)?;
    let modality_lut = match ModalityLut::read(&object, pixel_format.signed, plane.rescale, path) {
        Ok(lut) => lut,
        Err(error) => return Ok(FileKind::Unsupported { series_uid, series_description, error }),
    };
    let header = SliceHeader {
        path: path.to_path_buf(),
        series_uid,
        series_description,
        modality: text(&object, tags::MODALITY),
        sop_instance_uid: text(&object, tags::SOP_INSTANCE_UID),
        frame: 0,
        frames_in_file,
        rows: rows as usize,
        columns: columns as usize,
        pixel_spacing_mm: plane.pixel_spacing_mm,
        zero_pixel_spacing: plane.zero_pixel_spacing,
        position_mm: plane.position_mm,
        orientation: plane.orientation,
        slice_thickness_mm: plane.slice_thickness_mm,
        pixel_format,
        rescale: plane.rescale,
        modality_lut,
    };
    if !super::frames::has_functional_groups(&object) {
        if frames_in_file > 1 && ENHANCED_VOLUME_CLASSES.contains(&object.meta().media_storage_sop_class_uid()) {
            // An enhanced CT or MR file stripped of its functional groups: its frames are
            // slices without positions, stacked in file order ([`super::geometry`]).
            let frames = (0..frames_in_file).map(|frame| SliceHeader {
                frame,
                sop_instance_uid: format!("{}#{frame}", header.sop_instance_uid),
                ..header.clone()
            });
            return Ok(FileKind::Image(frames.collect()));
        }
        if frames_in_file > 1 {
            let error = VolumeError::Unsupported {
                what: "multi-frame DICOM image without per-frame positions (PerFrameFunctionalGroupsSequence)",
                value: format!("NumberOfFrames {frames_in_file}"),
                path: path.to_path_buf(),
            };
            return Ok(FileKind::Unsupported {
                series_uid: header.series_uid,
                series_description: header.series_description,
                error,
            });
        }
        return Ok(FileKind::Image(vec![header]));
    }
    let (series_uid, series_description) = (header.series_uid.clone(), header.series_description.clone());
    match super::frames::frame_headers(&object, header, path) {
        Ok(headers) => Ok(FileKind::Image(headers)),
        Err(error) => Ok(FileKind::Unsupported { series_uid, series_description, error }),
    }
}

/// The attributes that place an image plane and scale its values: top-level ones, or those
/// of one frame's functional groups ([`super::frames`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct PlaneAttributes {
    pub pixel_spacing_mm: Option<[f64; 2]>,
    pub zero_pixel_spacing: Option<[f64; 2]>,
    pub position_mm: Option<[f64; 3]>,
    pub orientation: Option<[f64; 6]>,
    pub slice_thickness_mm: Option<f64>,
    pub rescale: ValueScale,
}

impl PlaneAttributes {
    /// The attributes as found directly in `object` (absent ones `None`, rescale 1 and 0).
    pub fn read(object: &InMemDicomObject, path: &Path) -> Result<PlaneAttributes, VolumeError> {
        let mut plane = PlaneAttributes {
            pixel_spacing_mm: None,
            zero_pixel_spacing: None,
            position_mm: None,
            orientation: None,
            slice_thickness_mm: None,
            rescale: ValueScale::IDENTITY,
        };
        plane.update(object, path)?;
        Ok(plane)
    }

    /// Replaces each attribute that `object` holds (a functional group item, or the data set).
    pub fn update(&mut self, object: &InMemDicomObject, path: &Path) -> Result<(), VolumeError> {
        let slope = single_float(object, tags::RESCALE_SLOPE, "RescaleSlope", path)?;
        let intercept = single_float(object, tags::RESCALE_INTERCEPT, "RescaleIntercept", path)?;
        if slope == Some(0.0) {
            return Err(VolumeError::header("RescaleSlope", "must not be zero", path));
        }
        self.rescale.slope = slope.unwrap_or(self.rescale.slope);
        self.rescale.intercept = intercept.unwrap_or(self.rescale.intercept);
        // A spacing of 0 (written by some CR and secondary-capture software for "unknown") is
        // taken as absent: ImagerPixelSpacing, else 1 mm with a warning ([`super::geometry`]).
        for (tag, field) in [(tags::PIXEL_SPACING, "PixelSpacing"), (tags::IMAGER_PIXEL_SPACING, "ImagerPixelSpacing")]
        {
            let Some(spacing) = floats::<2>(object, tag, field, path)? else { continue };
            if spacing.iter().any(|s| *s < 0.0) {
                return Err(VolumeError::header(
                    field,
                    format!("{} \\ {} mm: both must be positive", spacing[0], spacing[1]),
                    path,
                ));
            }
            if spacing.contains(&0.0) {
                self.zero_pixel_spacing = Some(spacing);
                continue;
            }
            self.pixel_spacing_mm = Some(spacing);
            self.zero_pixel_spacing = None;
            break;
        }
        let thickness = match single_float(object, tags::SPACING_BETWEEN_SLICES, "SpacingBetweenSlices", path)? {
            Some(spacing) if spacing > 0.0 => Some(spacing),
            _ => single_float(object, tags::SLICE_THICKNESS, "SliceThickness", path)?
                .filter(|thickness| *thickness > 0.0),
        };
        self.slice_thickness_mm = thickness.or(self.slice_thickness_mm);
        if let Some(cosines) = floats::<6>(object, tags::IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient", path)? {
            self.orientation = Some(normalised_orientation(cosines, path)?);
        }
        if let Some(position) = floats::<3>(object, tags::IMAGE_POSITION_PATIENT, "ImagePositionPatient", path)? {
            self.position_mm = Some(position);
        }
        Ok(())
    }
}

/// Refuses a transfer syntax this build cannot decode, with the syntax's name.
fn check_transfer_syntax(uid: &str, path: &Path) -> Result<(), VolumeError> {
    if readable_transfer_syntax(uid) {
        return Ok(());
    }
    let name = match uid {
        "1.2.840.10008.1.2.1.99" => "Deflated Explicit VR Little Endian",
        "1.2.840.10008.1.2.4.50" => "JPEG Baseline",
        "1.2.840.10008.1.2.4.51" => "JPEG Extended",
        "1.2.840.10008.1.2.4.57" | "1.2.840.10008.1.2.4.70" => "JPEG Lossless",
        "1.2.840.10008.1.2.4.80" | "1.2.840.10008.1.2.4.81" => "JPEG-LS",
        "1.2.840.10008.1.2.4.90" => "JPEG 2000 lossless",
        "1.2.840.10008.1.2.4.91" => "JPEG 2000",
        "1.2.840.10008.1.2.5" => "RLE Lossless",
        "1.2.840.10008.1.2.4.201" | "1.2.840.10008.1.2.4.202" | "1.2.840.10008.1.2.4.203" => "HTJ2K",
        "1.2.840.10008.1.2.4.110" | "1.2.840.10008.1.2.4.111" | "1.2.840.10008.1.2.4.112" => "JPEG XL",
        "1.2.840.10008.1.2.4.100" | "1.2.840.10008.1.2.4.101" | "1.2.840.10008.1.2.4.102" => "MPEG video",
        _ => "unknown to this reader",
    };
    Err(VolumeError::Unsupported {
        what: "DICOM transfer syntax (convert the series, e.g. `gdcmconv --raw` or dcmtk's `dcmdjpeg`)",
        value: format!("{uid} ({name})"),
        path: path.to_path_buf(),
    })
}

/// Volumes are scalar: one grey sample per pixel.
fn check_grey(object: &DefaultDicomObject, path: &Path) -> Result<(), VolumeError> {
    let samples = unsigned(object, tags::SAMPLES_PER_PIXEL, "SamplesPerPixel", path)?.unwrap_or(1);
    let photometric = text(object, tags::PHOTOMETRIC_INTERPRETATION);
    if samples != 1 || !(photometric.is_empty() || photometric.starts_with("MONOCHROME")) {
        return Err(VolumeError::Unsupported {
            what: "DICOM colour image (only greyscale, SamplesPerPixel 1, can be a volume)",
            value: format!("SamplesPerPixel {samples}, PhotometricInterpretation {photometric}"),
            path: path.to_path_buf(),
        });
    }
    Ok(())
}

fn pixel_format(object: &DefaultDicomObject, path: &Path) -> Result<PixelFormat, VolumeError> {
    let bits_allocated = unsigned(object, tags::BITS_ALLOCATED, "BitsAllocated", path)?
        .ok_or_else(|| VolumeError::MissingField { field: "BitsAllocated", path: path.to_path_buf() })?;
    if bits_allocated != 8 && bits_allocated != 16 {
        return Err(VolumeError::Unsupported {
            what: "DICOM BitsAllocated (8 and 16 are read)",
            value: bits_allocated.to_string(),
            path: path.to_path_buf(),
        });
    }
    let bits_stored = unsigned(object, tags::BITS_STORED, "BitsStored", path)?.unwrap_or(bits_allocated);
    let high_bit = unsigned(object, tags::HIGH_BIT, "HighBit", path)?.unwrap_or(bits_stored.saturating_sub(1));
    if bits_stored == 0 || bits_stored > bits_allocated || high_bit + 1 != bits_stored {
        return Err(VolumeError::Unsupported {
            what: "DICOM bit layout (BitsStored must fit BitsAllocated with HighBit = BitsStored - 1)",
            value: format!("BitsAllocated {bits_allocated}, BitsStored {bits_stored}, HighBit {high_bit}"),
            path: path.to_path_buf(),
        });
    }
    let signed = match unsigned(object, tags::PIXEL_REPRESENTATION, "PixelRepresentation", path)?.unwrap_or(0) {
        0 => false,
        1 => true,
        other => {
            return Err(VolumeError::header(
                "PixelRepresentation",
                format!("{other} is neither 0 (unsigned) nor 1 (signed)"),
                path,
            ));
        }
    };
    Ok(PixelFormat { bits_allocated: bits_allocated as u16, bits_stored: bits_stored as u16, signed })
}

/// Row and column cosines, each scaled to unit length; they must be (nearly) orthogonal.
fn normalised_orientation(cosines: [f64; 6], path: &Path) -> Result<[f64; 6], VolumeError> {
    let row = [cosines[0], cosines[1], cosines[2]];
    let column = [cosines[3], cosines[4], cosines[5]];
    let row_length = row.iter().map(|c| c * c).sum::<f64>().sqrt();
    let column_length = column.iter().map(|c| c * c).sum::<f64>().sqrt();
    let dot: f64 = row.iter().zip(&column).map(|(a, b)| a * b).sum();
    // Scanners write 6-8 decimals; 1e-3 allows for that rounding and nothing more.
    if (row_length - 1.0).abs() > 1e-3 || (column_length - 1.0).abs() > 1e-3 || dot.abs() > 1e-3 {
        return Err(VolumeError::header(
            "ImageOrientationPatient",
            format!(
                "{cosines:?} are not two orthogonal unit vectors (lengths {row_length:.4}, {column_length:.4}, dot {dot:.4})"
            ),
            path,
        ));
    }
    let mut unit = [0.0; 6];
    for axis in 0..3 {
        unit[axis] = row[axis] / row_length;
        unit[axis + 3] = column[axis] / column_length;
    }
    Ok(unit)
}

/// A text attribute, trimmed; empty when absent or not text.
pub(super) fn text(object: &InMemDicomObject, tag: Tag) -> String {
    object
        .get(tag)
        .and_then(|element| element.to_str().ok())
        .map(|value| value.trim_matches([' ', '\0']).to_string())
        .unwrap_or_default()
}

/// An unsigned integer attribute (US, or IS text); `None` when absent or empty.
fn unsigned(object: &InMemDicomObject, tag: Tag, field: &'static str, path: &Path) -> Result<Option<u32>, VolumeError> {
    let Some(element) = object.get(tag) else {
        return Ok(None);
    };
    if is_blank(element.value()) {
        return Ok(None);
    }
    element.to_int::<u32>().map(Some).map_err(|error| VolumeError::header(field, error.to_string(), path))
}

/// A decimal-string attribute with exactly `N` finite values; `None` when absent or empty.
fn floats<const N: usize>(
    object: &InMemDicomObject,
    tag: Tag,
    field: &'static str,
    path: &Path,
) -> Result<Option<[f64; N]>, VolumeError> {
    let Some(element) = object.get(tag) else {
        return Ok(None);
    };
    if is_blank(element.value()) {
        return Ok(None);
    }
    let values = element.to_multi_float64().map_err(|error| VolumeError::header(field, error.to_string(), path))?;
    let array: [f64; N] = values
        .as_slice()
        .try_into()
        .map_err(|_| VolumeError::header(field, format!("has {} values, expected {N}", values.len()), path))?;
    if array.iter().any(|v| !v.is_finite()) {
        return Err(VolumeError::header(field, format!("{array:?} holds a non-finite value"), path));
    }
    Ok(Some(array))
}

fn single_float(
    object: &InMemDicomObject,
    tag: Tag,
    field: &'static str,
    path: &Path,
) -> Result<Option<f64>, VolumeError> {
    Ok(floats::<1>(object, tag, field, path)?.map(|[value]| value))
}

/// Zero-length or all-padding values count as absent (type 2 attributes may be sent empty).
fn is_blank<I, P>(value: &dicom_core::value::Value<I, P>) -> bool {
    match value.primitive() {
        Some(primitive) => primitive.multiplicity() == 0 || primitive.to_str().trim_matches([' ', '\0']).is_empty(),
        None => true,
    }
}
