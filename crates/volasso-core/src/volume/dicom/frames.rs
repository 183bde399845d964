//! Enhanced multi-frame images (Enhanced CT and MR, and their legacy-converted kin; PS3.3
//! C.7.6.16 Multi-frame Functional Groups): one file holds every slice as a frame, and each
//! frame's plane lies in its functional groups rather than in top-level attributes.
//!
//! [`frame_headers`] gives one [`SliceHeader`] per frame, so the series assembly orders and
//! checks frames exactly as it does single-frame files. A frame's attributes are looked up in
//! its item of the PerFrameFunctionalGroupsSequence, then in the SharedFunctionalGroupsSequence,
//! then at the top level: PlanePositionSequence (ImagePositionPatient),
//! PlaneOrientationSequence (ImageOrientationPatient), PixelMeasuresSequence (PixelSpacing,
//! SliceThickness, SpacingBetweenSlices) and PixelValueTransformationSequence (RescaleSlope,
//! RescaleIntercept).
//!
//! Never: reads pixel data, or guesses a frame's position (a multi-frame file whose frames
//! cannot each be placed is refused).

use super::header::{PlaneAttributes, SliceHeader};
use crate::volume::VolumeError;
use dicom_core::Tag;
use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;
use std::path::Path;

/// The functional group macros that place a frame and scale its values, in the order they
/// are applied (later ones override nothing: each names different attributes).
const PLANE_GROUPS: [Tag; 4] = [
    tags::PIXEL_MEASURES_SEQUENCE,
    tags::PLANE_ORIENTATION_SEQUENCE,
    tags::PLANE_POSITION_SEQUENCE,
    tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
];

/// True when `object` carries multi-frame functional groups.
pub(super) fn has_functional_groups(object: &InMemDicomObject) -> bool {
    object.get(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE).is_some()
        || object.get(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE).is_some()
}

/// One header per frame of `object`, starting from `base` (the file's top-level header, whose
/// `frames_in_file` is NumberOfFrames).
pub(super) fn frame_headers(
    object: &InMemDicomObject,
    base: SliceHeader,
    path: &Path,
) -> Result<Vec<SliceHeader>, VolumeError> {
    let first_item = |tag: Tag| object.get(tag).and_then(|element| element.items()).and_then(|items| items.first());
    let shared = first_item(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE);
    let per_frame = object.get(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE).and_then(|element| element.items());
    let frames = base.frames_in_file as usize;
    let per_frame = match per_frame {
        Some(items) if items.len() == frames => Some(items),
        Some(items) => {
            return Err(VolumeError::header(
                "PerFrameFunctionalGroupsSequence",
                format!("has {} items for NumberOfFrames {frames}", items.len()),
                path,
            ));
        }
        None if frames == 1 => None,
        None => {
            return Err(VolumeError::MissingField {
                field: "PerFrameFunctionalGroupsSequence",
                path: path.to_path_buf(),
            });
        }
    };
    let top = PlaneAttributes {
        pixel_spacing_mm: base.pixel_spacing_mm,
        zero_pixel_spacing: base.zero_pixel_spacing,
        position_mm: base.position_mm,
        orientation: base.orientation,
        slice_thickness_mm: base.slice_thickness_mm,
        rescale: base.rescale,
    };
    let mut shared_plane = top;
    if let Some(shared) = shared {
        apply_groups(&mut shared_plane, shared, path)?;
    }
    let mut headers = Vec::new();
    for frame in 0..frames {
        let mut plane = shared_plane;
        if let Some(items) = per_frame {
            apply_groups(&mut plane, &items[frame], path)?;
        }
        if base.modality_lut.is_some() && !plane.rescale.is_identity() {
            return Err(VolumeError::header(
                "ModalityLUTSequence",
                format!(
                    "is present beside frame {}'s RescaleSlope {} and RescaleIntercept {}: the file does not say which maps its values",
                    frame + 1,
                    plane.rescale.slope,
                    plane.rescale.intercept
                ),
                path,
            ));
        }
        if frames > 1 && plane.position_mm.is_none() {
            return Err(VolumeError::Dicom {
                problem: format!("frame {} of {frames} has no ImagePositionPatient (PlanePositionSequence)", frame + 1),
                path: path.to_path_buf(),
            });
        }
        headers.push(SliceHeader {
            frame: frame as u32,
            sop_instance_uid: format!("{}#{frame}", base.sop_instance_uid),
            pixel_spacing_mm: plane.pixel_spacing_mm,
            zero_pixel_spacing: plane.zero_pixel_spacing,
            position_mm: plane.position_mm,
            orientation: plane.orientation,
            slice_thickness_mm: plane.slice_thickness_mm,
            rescale: plane.rescale,
            ..base.clone()
        });
    }
    Ok(headers)
}

/// Applies the first item of each plane functional group that `groups` (one item of the
/// shared or per-frame sequence) holds.
fn apply_groups(plane: &mut PlaneAttributes, groups: &InMemDicomObject, path: &Path) -> Result<(), VolumeError> {
    for tag in PLANE_GROUPS {
        if let Some(item) = groups.get(tag).and_then(|element| element.items()).and_then(|items| items.first()) {
            plane.update(item, path)?;
        }
    }
    Ok(())
}
