//! A label volume as a binary DICOM Segmentation (PS3.3 A.51, C.8.20): one segment per class,
//! named as the class and coloured with its recommended display CIELab value; one frame per
//! (segment, slice) where the slice holds the segment (and the first slice for a segment that
//! holds no voxel, so every segment has a frame); each frame references its source image and
//! repeats its position. Frames are 1 bit per pixel, packed across frames, least significant
//! bit first (PS3.5 8.1.1).
//!
//! Never: writes fractional or overlapping segments (a voxel has one label), or frames that do
//! not lie exactly on a source slice.

use super::{
    ExportError, SEGMENTATION_STORAGE, SourceSeries, code, copy_patient_and_study, date_time_now, decimal, new_uid,
    put_equipment, sequence, text, texts, ushort, with_meta,
};
use dicom_core::{DataElement, PrimitiveValue, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileDicomObject, InMemDicomObject};

/// One class as a segment.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// The class name (SegmentLabel; at most 64 characters are kept).
    pub label: String,
    /// The class's colour, sRGB components in [0, 1].
    pub rgb: [f32; 3],
}

impl Segment {
    /// The segment of a class named `label` drawn with `style`: the colour at the start of its
    /// hue range, at its saturation and value.
    pub fn of_class(label: String, style: &volasso_core::transfer::ClassStyle) -> Segment {
        Segment { label, rgb: volasso_core::transfer::hsv_to_rgb(style.hue_degrees[0], style.saturation, style.value) }
    }
}

/// sRGB in [0, 1] to DICOM's scaled CIELab (PS3.3 C.10.7.1.1): L* 0..100 and a*, b* -128..127
/// each mapped onto 0..65535; D65 white, as highdicom and dcmqi convert.
pub fn cielab_value(rgb: [f32; 3]) -> [u16; 3] {
    let linear = rgb.map(|c| {
        let c = f64::from(c.clamp(0.0, 1.0));
        if c > 0.04045 { ((c + 0.055) / 1.055).powf(2.4) } else { c / 12.92 }
    });
    let [r, g, b] = linear;
    let x = (r * 0.4124 + g * 0.3576 + b * 0.1805) / 0.95047;
    let y = r * 0.2126 + g * 0.7152 + b * 0.0722;
    let z = (r * 0.0193 + g * 0.1192 + b * 0.9505) / 1.08883;
    let f = |t: f64| if t >= 0.008_856_451_679_035_631 { t.cbrt() } else { 841.0 / 108.0 * t + 4.0 / 29.0 };
    let (fx, fy, fz) = (f(x), f(y), f(z));
    let (lightness, a, b) = (116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz));
    let scale =
        |value: f64, low: f64, high: f64| ((value - low) / (high - low) * 65535.0).round().clamp(0.0, 65535.0) as u16;
    [scale(lightness, 0.0, 100.0), scale(a, -128.0, 127.0), scale(b, -128.0, 127.0)]
}

/// The Segmentation of `labels` (x fastest, the series' dims; 0 is no segment, k is
/// `segments[k - 1]`) on `source`.
pub fn segmentation(
    source: &SourceSeries,
    labels: &[u8],
    segments: &[Segment],
) -> Result<FileDicomObject<InMemDicomObject>, ExportError> {
    let [columns, rows, slices] = source.dims;
    let plane = columns * rows;
    let build = |problem: String| ExportError::Build { what: "Segmentation", problem };
    if labels.len() != plane * slices {
        return Err(build(format!("{} labels for {columns}x{rows}x{slices} voxels", labels.len())));
    }
    if segments.is_empty() || segments.len() > usize::from(u8::MAX) {
        return Err(build(format!("{} classes (1 to 255 can be segments)", segments.len())));
    }
    let (Ok(rows16), Ok(columns16)) = (u16::try_from(rows), u16::try_from(columns)) else {
        return Err(build(format!("{columns}x{rows} pixels is more than DICOM's 65535 per side")));
    };
    // (segment number, slice) of every frame, segments in order, slices in order.
    let mut present = vec![false; segments.len() * slices];
    for (z, slice) in labels.chunks_exact(plane).enumerate() {
        for &label in slice {
            if label > 0 && usize::from(label) <= segments.len() {
                present[(usize::from(label) - 1) * slices + z] = true;
            }
        }
    }
    let mut frames: Vec<(u16, usize)> = Vec::new();
    for segment in 0..segments.len() {
        let before = frames.len();
        frames.extend((0..slices).filter(|&z| present[segment * slices + z]).map(|z| (segment as u16 + 1, z)));
        if frames.len() == before {
            frames.push((segment as u16 + 1, 0));
        }
    }
    let mut pixels = vec![0u8; (frames.len() * plane).div_ceil(8).next_multiple_of(2)];
    for (index, &(segment, z)) in frames.iter().enumerate() {
        let slice = &labels[z * plane..(z + 1) * plane];
        let start = index * plane;
        for (offset, &label) in slice.iter().enumerate() {
            if u16::from(label) == segment {
                let bit = start + offset;
                pixels[bit / 8] |= 1 << (bit % 8);
            }
        }
    }

    let (date, time) = date_time_now();
    let series_number = source.text(tags::SERIES_NUMBER).trim().parse::<i64>().map_or(1000, |n| n + 1000);
    let mut object = InMemDicomObject::new_empty();
    object.put(text(tags::SOP_CLASS_UID, VR::UI, SEGMENTATION_STORAGE));
    object.put(text(tags::SOP_INSTANCE_UID, VR::UI, &new_uid("segmentation instance")));
    copy_patient_and_study(source, &mut object, true);
    // General and Segmentation Series.
    object.put(text(tags::MODALITY, VR::CS, "SEG"));
    object.put(text(tags::SERIES_INSTANCE_UID, VR::UI, &new_uid("segmentation series")));
    object.put(text(tags::SERIES_NUMBER, VR::IS, &series_number.to_string()));
    object.put(text(tags::SERIES_DESCRIPTION, VR::LO, "volasso segmentation"));
    object.put(text(tags::SERIES_DATE, VR::DA, &date));
    object.put(text(tags::SERIES_TIME, VR::TM, &time));
    put_equipment(&mut object);
    // General Image, Segmentation Image.
    object.put(text(tags::INSTANCE_NUMBER, VR::IS, "1"));
    object.put(text(tags::CONTENT_DATE, VR::DA, &date));
    object.put(text(tags::CONTENT_TIME, VR::TM, &time));
    object.put(texts(tags::IMAGE_TYPE, VR::CS, &["DERIVED".into(), "PRIMARY".into()]));
    object.put(text(tags::CONTENT_LABEL, VR::CS, "VOLASSO"));
    object.put(text(tags::CONTENT_DESCRIPTION, VR::LO, "volasso classes"));
    object.put(DataElement::new(tags::CONTENT_CREATOR_NAME, VR::PN, PrimitiveValue::Empty));
    object.put(text(tags::SEGMENTATION_TYPE, VR::CS, "BINARY"));
    object.put(text(tags::LOSSY_IMAGE_COMPRESSION, VR::CS, "00"));
    object.put(sequence(
        tags::SEGMENT_SEQUENCE,
        segments.iter().enumerate().map(|(index, s)| segment_item(index, s)).collect(),
    ));
    // Image Pixel.
    object.put(ushort(tags::SAMPLES_PER_PIXEL, 1));
    object.put(text(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, "MONOCHROME2"));
    object.put(ushort(tags::ROWS, rows16));
    object.put(ushort(tags::COLUMNS, columns16));
    object.put(ushort(tags::BITS_ALLOCATED, 1));
    object.put(ushort(tags::BITS_STORED, 1));
    object.put(ushort(tags::HIGH_BIT, 0));
    object.put(ushort(tags::PIXEL_REPRESENTATION, 0));
    // Multi-frame Functional Groups and Dimensions.
    object.put(text(tags::NUMBER_OF_FRAMES, VR::IS, &frames.len().to_string()));
    let organisation = new_uid("dimension organisation");
    object.put(sequence(
        tags::DIMENSION_ORGANIZATION_SEQUENCE,
        vec![InMemDicomObject::from_element_iter([text(tags::DIMENSION_ORGANIZATION_UID, VR::UI, &organisation)])],
    ));
    let dimension = |pointer, group, label: &str| {
        InMemDicomObject::from_element_iter([
            text(tags::DIMENSION_ORGANIZATION_UID, VR::UI, &organisation),
            DataElement::new(
                tags::DIMENSION_INDEX_POINTER,
                VR::AT,
                PrimitiveValue::Tags([pointer].into_iter().collect()),
            ),
            DataElement::new(
                tags::FUNCTIONAL_GROUP_POINTER,
                VR::AT,
                PrimitiveValue::Tags([group].into_iter().collect()),
            ),
            text(tags::DIMENSION_DESCRIPTION_LABEL, VR::LO, label),
        ])
    };
    object.put(sequence(
        tags::DIMENSION_INDEX_SEQUENCE,
        vec![
            dimension(
                tags::REFERENCED_SEGMENT_NUMBER,
                tags::SEGMENT_IDENTIFICATION_SEQUENCE,
                "ReferencedSegmentNumber",
            ),
            dimension(tags::IMAGE_POSITION_PATIENT, tags::PLANE_POSITION_SEQUENCE, "ImagePositionPatient"),
        ],
    ));
    let thickness = source.text(tags::SLICE_THICKNESS);
    let thickness = if thickness.is_empty() { decimal(source.slice_spacing_mm) } else { thickness };
    let spacing = source.text(tags::PIXEL_SPACING).split('\\').map(|v| v.trim().to_string()).collect::<Vec<_>>();
    let orientation =
        source.text(tags::IMAGE_ORIENTATION_PATIENT).split('\\').map(|v| v.trim().to_string()).collect::<Vec<_>>();
    let shared = InMemDicomObject::from_element_iter([
        sequence(
            tags::PIXEL_MEASURES_SEQUENCE,
            vec![InMemDicomObject::from_element_iter([
                texts(tags::PIXEL_SPACING, VR::DS, &spacing),
                text(tags::SLICE_THICKNESS, VR::DS, &thickness),
                text(tags::SPACING_BETWEEN_SLICES, VR::DS, &decimal(source.slice_spacing_mm)),
            ])],
        ),
        sequence(
            tags::PLANE_ORIENTATION_SEQUENCE,
            vec![InMemDicomObject::from_element_iter([texts(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, &orientation)])],
        ),
    ]);
    object.put(sequence(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE, vec![shared]));
    let per_frame = frames.iter().map(|&(segment, z)| frame_item(source, segment, z)).collect();
    object.put(sequence(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE, per_frame));
    // Common Instance Reference: the whole source series.
    let instances = source
        .images
        .iter()
        .map(|image| {
            InMemDicomObject::from_element_iter([
                text(tags::REFERENCED_SOP_CLASS_UID, VR::UI, &image.sop_class_uid),
                text(tags::REFERENCED_SOP_INSTANCE_UID, VR::UI, &image.sop_instance_uid),
            ])
        })
        .collect();
    object.put(sequence(
        tags::REFERENCED_SERIES_SEQUENCE,
        vec![InMemDicomObject::from_element_iter([
            text(tags::SERIES_INSTANCE_UID, VR::UI, &source.series_uid),
            sequence(tags::REFERENCED_INSTANCE_SEQUENCE, instances),
        ])],
    ));
    object.put(DataElement::new(tags::PIXEL_DATA, VR::OB, PrimitiveValue::from(pixels)));
    with_meta(object, "Segmentation")
}

/// A Segment Sequence item (Segment Description macro, C.8.20.2).
fn segment_item(index: usize, segment: &Segment) -> InMemDicomObject {
    let label: String = segment.label.chars().filter(|c| !c.is_control() && *c != '\\').take(64).collect();
    let label = if label.trim().is_empty() { format!("class {}", index + 1) } else { label };
    InMemDicomObject::from_element_iter([
        ushort(tags::SEGMENT_NUMBER, index as u16 + 1),
        text(tags::SEGMENT_LABEL, VR::LO, &label),
        sequence(tags::SEGMENTED_PROPERTY_CATEGORY_CODE_SEQUENCE, vec![code("85756007", "SCT", "Tissue")]),
        sequence(tags::SEGMENTED_PROPERTY_TYPE_CODE_SEQUENCE, vec![code("85756007", "SCT", "Tissue")]),
        text(tags::SEGMENT_ALGORITHM_TYPE, VR::CS, "SEMIAUTOMATIC"),
        text(tags::SEGMENT_ALGORITHM_NAME, VR::LO, "volasso"),
        DataElement::new(
            tags::RECOMMENDED_DISPLAY_CIE_LAB_VALUE,
            VR::US,
            PrimitiveValue::U16(cielab_value(segment.rgb).into_iter().collect()),
        ),
    ])
}

/// A Per-Frame Functional Groups item: the source image, its position, the segment.
fn frame_item(source: &SourceSeries, segment: u16, z: usize) -> InMemDicomObject {
    let image = &source.images[z];
    let source_image = InMemDicomObject::from_element_iter([
        text(tags::REFERENCED_SOP_CLASS_UID, VR::UI, &image.sop_class_uid),
        text(tags::REFERENCED_SOP_INSTANCE_UID, VR::UI, &image.sop_instance_uid),
        sequence(
            tags::PURPOSE_OF_REFERENCE_CODE_SEQUENCE,
            vec![code("121322", "DCM", "Source image for image processing operation")],
        ),
        // The frame lies on its source slice, pixel for pixel.
        text(tags::SPATIAL_LOCATIONS_PRESERVED, VR::CS, "YES"),
    ]);
    let derivation = InMemDicomObject::from_element_iter([
        sequence(tags::DERIVATION_CODE_SEQUENCE, vec![code("113076", "DCM", "Segmentation")]),
        sequence(tags::SOURCE_IMAGE_SEQUENCE, vec![source_image]),
    ]);
    InMemDicomObject::from_element_iter([
        sequence(tags::DERIVATION_IMAGE_SEQUENCE, vec![derivation]),
        sequence(
            tags::FRAME_CONTENT_SEQUENCE,
            vec![InMemDicomObject::from_element_iter([DataElement::new(
                tags::DIMENSION_INDEX_VALUES,
                VR::UL,
                PrimitiveValue::U32([u32::from(segment), z as u32 + 1].into_iter().collect()),
            )])],
        ),
        sequence(
            tags::PLANE_POSITION_SEQUENCE,
            vec![InMemDicomObject::from_element_iter([texts(tags::IMAGE_POSITION_PATIENT, VR::DS, &image.position)])],
        ),
        sequence(
            tags::SEGMENT_IDENTIFICATION_SEQUENCE,
            vec![InMemDicomObject::from_element_iter([ushort(tags::REFERENCED_SEGMENT_NUMBER, segment)])],
        ),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dicom_out::SourceImage;
    use std::path::PathBuf;

    /// A series of 2 slices of 3 x 2 pixels, without a file behind it.
    fn tiny_series() -> SourceSeries {
        let first = InMemDicomObject::from_element_iter([
            text(tags::STUDY_INSTANCE_UID, VR::UI, "1.2.3"),
            text(tags::FRAME_OF_REFERENCE_UID, VR::UI, "1.2.3.4"),
            text(tags::PIXEL_SPACING, VR::DS, "0.5\\0.5"),
            text(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, "1\\0\\0\\0\\1\\0"),
        ]);
        let image = |z: usize| SourceImage {
            path: PathBuf::from(format!("slice{z}")),
            sop_class_uid: "1.2.840.10008.5.1.4.1.1.2".into(),
            sop_instance_uid: format!("1.2.3.5.{z}"),
            position: vec!["0".into(), "0".into(), format!("{}", z * 2)],
        };
        SourceSeries {
            dims: [3, 2, 2],
            images: vec![image(0), image(1)],
            series_uid: "1.2.3.6".into(),
            first,
            slice_spacing_mm: 2.0,
        }
    }

    #[test]
    fn frames_hold_each_segments_slices_bit_packed_least_significant_first() {
        // Slice 0: class 1 at x = 0 and 2 of row 0; slice 1: class 2 at (1, 1). Class 3 has none.
        let labels = [1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 2, 0];
        let segments: Vec<Segment> =
            ["a", "b", "c"].iter().map(|name| Segment { label: name.to_string(), rgb: [1.0, 0.0, 0.0] }).collect();
        let object = segmentation(&tiny_series(), &labels, &segments).unwrap();
        // Class 1 on slice 0, class 2 on slice 1, class 3 (empty) on slice 0.
        assert_eq!(object.element(tags::NUMBER_OF_FRAMES).unwrap().to_str().unwrap(), "3");
        let pixels = object.element(tags::PIXEL_DATA).unwrap().to_bytes().unwrap();
        // 3 frames of 6 bits: bits 0 and 2 (frame 1), bit 6 + 4 = 10 (frame 2), none (frame 3).
        assert_eq!(&pixels[..], &[0b0000_0101, 0b0000_0100, 0, 0]);
        let frames = object.element(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE).unwrap().items().unwrap();
        let source_of = |frame: &InMemDicomObject| {
            let derivation = &frame.element(tags::DERIVATION_IMAGE_SEQUENCE).unwrap().items().unwrap()[0];
            let source = &derivation.element(tags::SOURCE_IMAGE_SEQUENCE).unwrap().items().unwrap()[0];
            source.element(tags::REFERENCED_SOP_INSTANCE_UID).unwrap().to_str().unwrap().into_owned()
        };
        let sources: Vec<String> = frames.iter().map(source_of).collect();
        assert_eq!(sources, ["1.2.3.5.0", "1.2.3.5.1", "1.2.3.5.0"]);
        assert!(segmentation(&tiny_series(), &labels[..11], &segments).is_err(), "labels of another size");
    }

    #[test]
    fn cielab_of_white_black_and_red() {
        // Neutral a* and b* are 32896 (0 on -128..127); sRGB's primaries sum to D65 within 1e-4.
        let near = |got: [u16; 3], want: [u16; 3]| got.iter().zip(want).all(|(&g, w)| g.abs_diff(w) <= 4);
        assert!(near(cielab_value([1.0, 1.0, 1.0]), [65535, 32896, 32896]), "{:?}", cielab_value([1.0; 3]));
        assert!(near(cielab_value([0.0, 0.0, 0.0]), [0, 32896, 32896]), "{:?}", cielab_value([0.0; 3]));
        // sRGB red is L* 53.24, a* 80.09, b* 67.20.
        let [l, a, b] = cielab_value([1.0, 0.0, 0.0]);
        assert!((f64::from(l) / 655.35 - 53.24).abs() < 0.05, "{l}");
        assert!((f64::from(a) * 255.0 / 65535.0 - 128.0 - 80.09).abs() < 0.05, "{a}");
        assert!((f64::from(b) * 255.0 / 65535.0 - 128.0 - 67.20).abs() < 0.05, "{b}");
    }
}
