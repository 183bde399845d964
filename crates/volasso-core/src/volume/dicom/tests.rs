//! Series assembly on synthetic series written with dicom-object (known geometry and values),
//! and malformed inputs. Real scans are in `real_data_tests.rs`.

use super::synthetic::{EXPLICIT_LITTLE, IMPLICIT_LITTLE, SyntheticSlice};
use super::*;
use dicom_dictionary_std::tags;

fn error_text(result: Result<DicomImport, VolumeError>) -> String {
    match result {
        Ok(import) => panic!("expected an error, got a {:?} volume", import.volume.dims),
        Err(error) => error.to_string(),
    }
}

/// Sagittal slices (rows along -z, columns along +y, normal -x) at x = 0, -1.5, -3: stored
/// value `100 * k + 10 * row + column` for the k-th slice along the normal. Files are named
/// so that name order is not slice order.
fn write_sagittal_series(folder: &Path, series_uid: &str, transfer_syntax: &'static str) {
    let names = ["c.dcm", "a.dcm", "b.dcm"];
    for (k, name) in names.iter().enumerate() {
        let mut slice = SyntheticSlice::axial(
            series_uid,
            &format!("{series_uid}.{k}"),
            [4, 3],
            [-1.5 * k as f64, 10.0, 20.0],
            |column, row| (100 * k + 10 * row + column) as i16,
        );
        slice.orientation = [0.0, 1.0, 0.0, 0.0, 0.0, -1.0];
        slice.pixel_spacing_mm = [0.8, 0.6];
        slice.intercept = -1024.0;
        slice.transfer_syntax = transfer_syntax;
        slice.write(&folder.join(name));
    }
}

#[test]
fn regular_series_is_sorted_along_the_normal_and_copied_exactly() {
    for transfer_syntax in [EXPLICIT_LITTLE, IMPLICIT_LITTLE] {
        let folder = tempfile::tempdir().unwrap();
        write_sagittal_series(folder.path(), "1.2.3", transfer_syntax);
        std::fs::write(folder.path().join("notes.txt"), "not DICOM").unwrap();
        let import = read_series(folder.path(), &DicomOptions::default()).unwrap();
        let volume = &import.volume;
        assert_eq!(volume.dims, [4, 3, 3]);
        // PixelSpacing 0.8 (between rows) \ 0.6 (between columns) -> x 0.6, y 0.8.
        assert_eq!(volume.spacing_mm, [0.6, 0.8, 1.5]);
        assert_eq!(volume.voxel_type, VoxelType::I16);
        assert!(import.warnings.is_empty(), "{:?}", import.warnings);
        let names: Vec<_> = import.files.iter().map(|f| f.file_name().unwrap()).collect();
        assert_eq!(names, ["c.dcm", "a.dcm", "b.dcm"]);
        for (z, y, x) in [(0, 0, 0), (1, 2, 3), (2, 1, 2)] {
            let expected = (100 * z + 10 * y + x) as f64 - 1024.0;
            assert_eq!(volume.value_at(x, y, z), expected);
        }
        assert_eq!(import.series_uid, "1.2.3");
        assert_eq!(import.description, "synthetic");
    }
}

#[test]
fn several_series_are_listed_and_one_is_chosen_by_uid() {
    let folder = tempfile::tempdir().unwrap();
    write_sagittal_series(folder.path(), "1.2.3", EXPLICIT_LITTLE);
    for k in 0..2 {
        SyntheticSlice::axial("9.8.7", &format!("9.8.7.{k}"), [2, 2], [0.0, 0.0, k as f64], |_, _| 5)
            .write(&folder.path().join(format!("other{k}.dcm")));
    }
    let message = error_text(read_series(folder.path(), &DicomOptions::default()));
    for needle in ["2 image series", "--series", "1.2.3", "(3 slices)", "9.8.7", "(2 slices)"] {
        assert!(message.contains(needle), "'{needle}' missing from: {message}");
    }
    let options = DicomOptions { series_uid: Some("9.8.7".into()), ..DicomOptions::default() };
    let import = read_series(folder.path(), &options).unwrap();
    assert_eq!(import.volume.dims, [2, 2, 2]);
    assert_eq!(import.series_uid, "9.8.7");
    let options = DicomOptions { series_uid: Some("4.4".into()), ..DicomOptions::default() };
    let message = error_text(read_series(folder.path(), &options));
    assert!(message.contains("4.4") && message.contains("1.2.3"), "{message}");
}

/// Field linear in space (mm), integer at every pixel centre of the tilted series below.
fn linear_field(u: f64, v: f64, w: f64) -> f64 {
    100.0 + 3.0 * u + 5.0 * v + 7.0 * w
}

/// Axial slices at uneven z (gaps 2, 2, 6, 2 mm), each shifted in y by z / 2 mm (a 26.6 degree
/// tilt), 8 columns 1 mm apart, 6 rows 2 mm apart, holding `linear_field` in HU.
fn write_tilted_series(folder: &Path) -> Vec<[f64; 3]> {
    let positions: Vec<[f64; 3]> = [0.0, 2.0, 4.0, 10.0, 12.0].iter().map(|z| [0.0, z / 2.0, *z]).collect();
    for (k, position) in positions.iter().enumerate().rev() {
        let mut slice = SyntheticSlice::axial("5.5", &format!("5.5.{k}"), [8, 6], *position, |column, row| {
            let hu = linear_field(column as f64, position[1] + 2.0 * row as f64, position[2]);
            (hu + 1024.0) as i16
        });
        slice.pixel_spacing_mm = [2.0, 1.0];
        slice.intercept = -1024.0;
        slice.write(&folder.join(format!("{k}.dcm")));
    }
    positions
}

/// Options that open a series across a missing slice.
fn allowing_gaps() -> DicomOptions {
    DicomOptions { allow_gaps: true, ..DicomOptions::default() }
}

#[test]
fn tilted_uneven_series_is_resampled_reproducing_a_linear_field() {
    let folder = tempfile::tempdir().unwrap();
    let positions = write_tilted_series(folder.path());
    // The 6 mm gap is three times the 2 mm spacing: room for two slices that are not there.
    let message = error_text(read_series(folder.path(), &DicomOptions::default()));
    for needle in ["missing slice", "6.00 mm gap between slices 3 and 4", "3.0 times", "--allow-gaps"] {
        assert!(message.contains(needle), "'{needle}' missing from: {message}");
    }
    let import = read_series(folder.path(), &allowing_gaps()).unwrap();
    let volume = &import.volume;
    // y: 6 rows plus 6 mm / 2 mm = 3 rows of shift; z: 12 mm in steps of 2 mm.
    assert_eq!(volume.dims, [8, 9, 7]);
    assert_eq!(volume.spacing_mm, [1.0, 2.0, 2.0]);
    assert_eq!(volume.voxel_type, VoxelType::F32);
    assert_eq!(import.warnings.len(), 2, "{:?}", import.warnings);
    assert!(import.warnings[0].starts_with("opened with a missing slice (--allow-gaps): the 6.00 mm gap"));
    let warning = &import.warnings[1];
    for needle in ["gantry tilt 26.6 deg", "uneven slice gaps 2.00..6.00 mm", "1.000 x 2.000 x 2.000 mm"] {
        assert!(warning.contains(needle), "'{needle}' missing from: {warning}");
    }
    let pad = linear_field(0.0, 0.0, 0.0) as f32;
    // Row coordinate of output position v in slice k: exact between pixel centres, padded
    // beyond half a pixel outside them.
    let row_in_slice = |k: usize, v: f64| (v - positions[k][1]) / 2.0;
    let inside = |k: usize, v: f64| (0.0..=5.0).contains(&row_in_slice(k, v));
    let outside = |k: usize, v: f64| !(-0.5..=5.5).contains(&row_in_slice(k, v));
    let (mut checked_inside, mut checked_pad) = (0, 0);
    for z in 0..7 {
        let w = 2.0 * z as f64;
        let above = positions.iter().position(|p| p[2] >= w).unwrap();
        let below = positions.iter().rposition(|p| p[2] <= w).unwrap();
        for y in 0..9 {
            let v = 2.0 * y as f64;
            for x in 0..8 {
                let value = volume.value_at(x, y, z) as f32;
                if inside(below, v) && inside(above, v) {
                    let expected = linear_field(x as f64, v, w) as f32;
                    assert!((value - expected).abs() < 1e-3, "({x},{y},{z}): {value} != {expected}");
                    checked_inside += 1;
                } else if outside(below, v) && outside(above, v) {
                    assert_eq!(value, pad, "({x},{y},{z}) lies outside every slice");
                    checked_pad += 1;
                }
            }
        }
    }
    assert!(checked_inside > 250 && checked_pad > 30, "{checked_inside} {checked_pad}");

    let refuse = DicomOptions { resample: Resample::Refuse, ..allowing_gaps() };
    let message = error_text(read_series(folder.path(), &refuse));
    assert!(message.contains("gantry tilt 26.6 deg") && message.contains("2.00..6.00 mm"), "{message}");
}

#[test]
fn uneven_gaps_reproduce_a_ramp_along_the_normal_at_any_slice_spacing() {
    let folder = tempfile::tempdir().unwrap();
    for (k, z) in [0.0, 1.0, 3.0, 7.0].into_iter().enumerate() {
        SyntheticSlice::axial("6.6", &format!("6.6.{k}"), [3, 2], [0.0, 0.0, z], |column, _| {
            (10.0 * z) as i16 + column as i16
        })
        .write(&folder.path().join(format!("{k}.dcm")));
    }
    // Gaps 1, 2, 4: the 4 mm gap is twice the 2 mm median, room for a slice at 5 mm.
    let message = error_text(read_series(folder.path(), &DicomOptions::default()));
    assert!(message.contains("4.00 mm gap between slices 3 and 4"), "{message}");
    let import = read_series(folder.path(), &allowing_gaps()).unwrap();
    // Median 2, smallest gap >= 1 is 1 mm.
    assert_eq!(import.volume.dims, [3, 2, 8]);
    assert_eq!(import.volume.spacing_mm[2], 1.0);
    assert!(import.warnings[1].contains("uneven slice gaps 1.00..4.00 mm"));
    assert!(!import.warnings[1].contains("tilt"));
    for z in 0..8 {
        for x in 0..3 {
            assert_eq!(import.volume.value_at(x, 1, z), 10.0 * z as f64 + x as f64);
        }
    }
    let options = DicomOptions { slice_spacing_mm: Some(3.0), ..allowing_gaps() };
    let import = read_series(folder.path(), &options).unwrap();
    assert_eq!(import.volume.dims, [3, 2, 3]);
    let ramp: Vec<f64> = (0..3).map(|z| import.volume.value_at(0, 0, z)).collect();
    assert_eq!(ramp, [0.0, 30.0, 60.0]);
}

#[test]
fn repeated_files_are_dropped_and_different_images_at_one_position_refused() {
    let folder = tempfile::tempdir().unwrap();
    write_sagittal_series(folder.path(), "1.2.3", EXPLICIT_LITTLE);
    std::fs::copy(folder.path().join("a.dcm"), folder.path().join("a_copy.dcm")).unwrap();
    let import = read_series(folder.path(), &DicomOptions::default()).unwrap();
    assert_eq!(import.volume.dims, [4, 3, 3]);
    assert_eq!(import.files.len(), 3);
    assert!(import.warnings[0].contains("a_copy.dcm") && import.warnings[0].contains("same SOPInstanceUID"));

    let mut other = SyntheticSlice::axial("1.2.3", "1.2.3.99", [4, 3], [-1.5, 10.0, 20.0], |_, _| 0);
    other.orientation = [0.0, 1.0, 0.0, 0.0, 0.0, -1.0];
    other.pixel_spacing_mm = [0.8, 0.6];
    other.write(&folder.path().join("phase2.dcm"));
    let message = error_text(read_series(folder.path(), &DicomOptions::default()));
    assert!(message.contains("two different images") && message.contains("phase2.dcm"), "{message}");
}

#[test]
fn inconsistent_or_incomplete_series_are_refused_with_the_file_named() {
    let write_pair = |second: SyntheticSlice| {
        let folder = tempfile::tempdir().unwrap();
        SyntheticSlice::axial("7.7", "7.7.0", [4, 4], [0.0, 0.0, 0.0], |_, _| 1)
            .write(&folder.path().join("first.dcm"));
        second.write(&folder.path().join("second.dcm"));
        let message = error_text(read_series(folder.path(), &DicomOptions::default()));
        assert!(message.contains("second.dcm") || message.contains("first.dcm"), "{message}");
        message
    };
    let base = SyntheticSlice::axial("7.7", "7.7.1", [4, 4], [0.0, 0.0, 1.0], |_, _| 1);
    let mut smaller = SyntheticSlice::axial("7.7", "7.7.1", [4, 3], [0.0, 0.0, 1.0], |_, _| 1);
    smaller.rows = 3;
    assert!(write_pair(smaller).contains("image size"));
    let mut spacing = base.clone();
    spacing.pixel_spacing_mm = [1.0, 0.5];
    assert!(write_pair(spacing).contains("PixelSpacing"));
    let mut rotated = base.clone();
    rotated.orientation = [1.0, 0.0, 0.0, 0.0, 0.0, -1.0];
    assert!(write_pair(rotated).contains("ImageOrientationPatient"));
    let mut unplaced = base.clone();
    unplaced.position_mm = None;
    assert!(write_pair(unplaced).contains("ImagePositionPatient is missing"));
    let mut without_pixels = base.clone();
    without_pixels.with_pixel_data = false;
    let message = write_pair(without_pixels);
    assert!(message.contains("PixelData") && message.contains("second.dcm"), "{message}");
    let mut colour = base;
    colour.samples_per_pixel = 3;
    assert!(write_pair(colour).contains("colour"));
}

#[test]
fn a_single_file_without_position_or_pixel_data() {
    let folder = tempfile::tempdir().unwrap();
    let mut slice = SyntheticSlice::axial("8.8", "8.8.0", [3, 2], [0.0; 3], |column, row| (column * row) as i16);
    slice.position_mm = None;
    let path = folder.path().join("one.dcm");
    slice.write(&path);
    let import = read_series(&path, &DicomOptions::default()).unwrap();
    assert_eq!(import.volume.dims, [3, 2, 1]);
    assert_eq!(import.volume.value_at(2, 1, 0), 2.0);
    slice.with_pixel_data = false;
    slice.write(&path);
    let error = read_series(&path, &DicomOptions::default()).unwrap_err();
    assert!(matches!(&error, VolumeError::MissingField { field: "PixelData", path: p } if p == &path), "{error}");
}

#[test]
fn truncated_files_give_errors_not_panics() {
    let original =
        std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/dicom/ct_small.dcm")).unwrap();
    let folder = tempfile::tempdir().unwrap();
    let mut lengths: Vec<usize> = (0..300).chain((300..original.len()).step_by(97)).collect();
    lengths.push(original.len() - 1);
    for length in lengths {
        let path = folder.path().join("cut.dcm");
        std::fs::write(&path, &original[..length]).unwrap();
        let _ = looks_like_dicom(&path);
        assert!(
            read_series(&path, &DicomOptions::default()).is_err(),
            "a copy cut at {length} of {} bytes was accepted",
            original.len()
        );
    }
}

#[test]
fn folders_without_image_series_are_errors() {
    let folder = tempfile::tempdir().unwrap();
    let message = error_text(read_series(folder.path(), &DicomOptions::default()));
    assert!(message.contains("no DICOM image series"), "{message}");
    std::fs::write(folder.path().join("readme.txt"), "hello").unwrap();
    std::fs::write(folder.path().join("volume.raw"), vec![0u8; 4096]).unwrap();
    assert!(!looks_like_dicom(folder.path()));
    let message = error_text(read_series(folder.path(), &DicomOptions::default()));
    assert!(message.contains("no DICOM image series") && message.contains("2 other files"), "{message}");
    // A DICOM header without the rest is skipped with a warning, then nothing is left.
    let original =
        std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/dicom/ct_small.dcm")).unwrap();
    std::fs::write(folder.path().join("cut.dcm"), &original[..400]).unwrap();
    assert!(looks_like_dicom(folder.path()));
    let message = error_text(read_series(folder.path(), &DicomOptions::default()));
    assert!(message.contains("1 unreadable"), "{message}");
}

#[test]
fn a_series_that_cannot_be_read_is_skipped_with_a_warning_when_another_can() {
    let folder = tempfile::tempdir().unwrap();
    write_sagittal_series(folder.path(), "1.2.3", EXPLICIT_LITTLE);
    let mut colour = SyntheticSlice::axial("4.5.6", "4.5.6.0", [2, 2], [0.0; 3], |_, _| 0);
    colour.samples_per_pixel = 3;
    colour.write(&folder.path().join("screenshot.dcm"));
    let import = read_series(folder.path(), &DicomOptions::default()).unwrap();
    assert_eq!(import.series_uid, "1.2.3");
    assert_eq!(import.warnings.len(), 1, "{:?}", import.warnings);
    assert!(import.warnings[0].contains("skipped series 4.5.6") && import.warnings[0].contains("colour"));
    let options = DicomOptions { series_uid: Some("4.5.6".into()), ..DicomOptions::default() };
    let error = read_series(folder.path(), &options).unwrap_err();
    assert!(matches!(error, VolumeError::Unsupported { .. }), "{error}");
}

#[test]
fn a_pixel_spacing_of_zero_reads_as_1_mm_with_a_warning_and_a_negative_one_is_refused() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("cr.dcm");
    let mut slice = SyntheticSlice::axial("5.5", "5.5.1", [3, 2], [0.0, 0.0, 0.0], |column, row| (column + row) as i16);
    slice.pixel_spacing_mm = [0.0, 0.0];
    slice.write(&path);
    let import = read_series(&path, &DicomOptions::default()).unwrap();
    assert_eq!(import.volume.spacing_mm[..2], [1.0, 1.0]);
    assert_eq!(import.warnings, ["PixelSpacing is 0 \\ 0 mm (0 means unknown): assuming 1 mm square pixels"]);
    assert_eq!(import.volume.value_at(2, 1, 0), 3.0);
    slice.pixel_spacing_mm = [-0.5, 0.5];
    slice.write(&path);
    let message = error_text(read_series(&path, &DicomOptions::default()));
    assert!(message.contains("PixelSpacing") && message.contains("-0.5 \\ 0.5 mm: both must be positive"), "{message}");
}

/// Rewrites the PixelData of `path` (16-bit samples) with `extra` words after the image.
fn append_to_pixel_data(path: &Path, extra: &[u16]) {
    let mut object = dicom_object::open_file(path).unwrap();
    let mut words: Vec<u16> = object.element(tags::PIXEL_DATA).unwrap().to_multi_int::<u16>().unwrap();
    words.extend_from_slice(extra);
    object.put(dicom_core::DataElement::new(
        tags::PIXEL_DATA,
        dicom_core::VR::OW,
        dicom_core::value::PrimitiveValue::U16(words.into()),
    ));
    object.write_to_file(path).unwrap();
}

#[test]
fn zero_padding_after_native_pixel_data_is_ignored_with_a_warning_and_anything_else_refused() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("padded.dcm");
    let slice =
        SyntheticSlice::axial("6.6", "6.6.1", [4, 4], [0.0, 0.0, 0.0], |column, row| (10 * row + column) as i16);
    // Up to one word short of a frame (16 words) of zeros: read, and said.
    slice.write(&path);
    append_to_pixel_data(&path, &[0; 15]);
    let import = read_series(&path, &DicomOptions::default()).unwrap();
    assert_eq!(import.volume.value_at(3, 3, 0), 33.0);
    assert_eq!(import.warnings.len(), 1);
    assert!(import.warnings[0].ends_with("its PixelData ends in 30 bytes of zero padding after the image, ignored"));
    // Anything but zeros, or a whole frame more: the header does not describe the pixels.
    for extra in [vec![0, 0, 7, 0], vec![0; 16]] {
        slice.write(&path);
        append_to_pixel_data(&path, &extra);
        let message = error_text(read_series(&path, &DicomOptions::default()));
        assert!(message.contains("the header does not describe the pixels"), "{message}");
    }
}

/// A 3-frame, 2 x 2 MR file of SOP class `sop_class` without functional groups or positions,
/// with ImageOrientationPatient and SpacingBetweenSlices 2.5; frame k holds 10 k + pixel index.
fn write_frames_without_groups(path: &Path, sop_class: &str) {
    use dicom_core::value::{C, PrimitiveValue};
    use dicom_core::{DataElement, VR};
    let us = |value: u16| PrimitiveValue::U16(C::from_elem(value, 1));
    let words: C<u16> = (0..3u16).flat_map(|k| (0..4u16).map(move |i| 10 * k + i)).collect();
    let elements = vec![
        DataElement::new(tags::SOP_CLASS_UID, VR::UI, sop_class),
        DataElement::new(tags::SOP_INSTANCE_UID, VR::UI, "9.9.1"),
        DataElement::new(tags::MODALITY, VR::CS, "MR"),
        DataElement::new(tags::SERIES_INSTANCE_UID, VR::UI, "9.9"),
        DataElement::new(tags::SPACING_BETWEEN_SLICES, VR::DS, "2.5"),
        DataElement::new(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, "1\\0\\0\\0\\1\\0"),
        DataElement::new(tags::SAMPLES_PER_PIXEL, VR::US, us(1)),
        DataElement::new(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, "MONOCHROME2"),
        DataElement::new(tags::NUMBER_OF_FRAMES, VR::IS, "3"),
        DataElement::new(tags::ROWS, VR::US, us(2)),
        DataElement::new(tags::COLUMNS, VR::US, us(2)),
        DataElement::new(tags::BITS_ALLOCATED, VR::US, us(16)),
        DataElement::new(tags::BITS_STORED, VR::US, us(12)),
        DataElement::new(tags::HIGH_BIT, VR::US, us(11)),
        DataElement::new(tags::PIXEL_REPRESENTATION, VR::US, us(0)),
        DataElement::new(tags::PIXEL_DATA, VR::OW, PrimitiveValue::U16(words)),
    ];
    dicom_object::InMemDicomObject::from_element_iter(elements)
        .with_meta(dicom_object::FileMetaTableBuilder::new().transfer_syntax(EXPLICIT_LITTLE))
        .unwrap()
        .write_to_file(path)
        .unwrap();
}

#[test]
fn an_enhanced_mr_without_functional_groups_stacks_its_frames_in_file_order_without_orientation() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("emr.dcm");
    write_frames_without_groups(&path, "1.2.840.10008.5.1.4.1.1.4.1");
    let import = read_series(&path, &DicomOptions::default()).unwrap();
    let volume = &import.volume;
    assert_eq!((volume.dims, volume.spacing_mm), ([2, 2, 3], [1.0, 1.0, 2.5]));
    assert_eq!((0..3).map(|z| volume.value_at(1, 1, z)).collect::<Vec<_>>(), [3.0, 13.0, 23.0]);
    // File order may run either way through the patient: no orientation is claimed.
    assert_eq!(volume.orientation, None);
    assert!(import.warnings[0].contains("stacked in file order, 2.5 mm apart"), "{:?}", import.warnings);
    // Other multi-frame classes (here MR Image Storage) without positions stay refused.
    write_frames_without_groups(&path, "1.2.840.10008.5.1.4.1.1.4");
    let message = error_text(read_series(&path, &DicomOptions::default()));
    assert!(message.contains("multi-frame DICOM image without per-frame positions"), "{message}");
}
