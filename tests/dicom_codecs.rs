//! Compressed and multi-frame DICOM read to the same voxels as the uncompressed series: copies
//! of the Philips phantom made with dcmtk (JPEG Lossless SV1, JPEG-LS lossless, RLE Lossless,
//! Deflated Explicit VR Little Endian) and an Enhanced CT file built from it here (frames in
//! reverse order, positions in per-frame functional groups), itself compressed by dcmtk; and a
//! folder of several series listed for the chooser (`series-picker.touch` in `replay` shows
//! each series as a card of its own). A 12-bit lossy JPEG copy (dcmtk's `dcmcjpeg +ee`) reads
//! to exactly dcmtk's own decoding. Files pydicom decodes (a Modality LUT, attributes stored as
//! UN, padded PixelData, an enhanced MR without functional groups, 12-bit JPEG, a PixelSpacing
//! of 0) read to pydicom's voxels (`scripts/pydicom_reference.py` makes them and pydicom's
//! values).
//!
//! dcmtk is a test dependency (`.ci/run` installs it); without it the dcmtk cases say so and
//! are skipped, except the comparison with pydicom, which needs dcmtk and python3 with pydicom
//! (`.ci/run` installs both) and fails without them.

use crate::support::data;
use dicom_core::value::{C, DataSetSequence, PrimitiveValue, Value};
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
use std::path::{Path, PathBuf};
use std::process::Command;
use volasso::volume::dicom::{DicomOptions, PatientShown, list_series, read_series};
use volasso::volume::limits::ReadLimits;

/// True when dcmtk's tools run; else prints why the dcmtk cases are skipped.
pub fn dcmtk_available() -> bool {
    let found = Command::new("dcmdump").arg("--version").output().is_ok_and(|output| output.status.success());
    if !found {
        eprintln!("SKIPPED: dcmtk is not installed (apt-get install dcmtk; .ci/run installs it)");
    }
    found
}

/// Runs one dcmtk tool `program args... input output`.
fn dcmtk(program: &str, args: &[&str], input: &Path, output: &Path) {
    let result = Command::new(program).args(args).arg(input).arg(output).output().expect("dcmtk runs");
    assert!(result.status.success(), "{program} {input:?}: {}", String::from_utf8_lossy(&result.stderr));
}

pub fn philips_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(data("dicom/philips_phantom_5mm"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.file_name().unwrap().to_string_lossy().starts_with('I'))
        .collect();
    files.sort();
    files
}

/// Asserts that the series in `folder` reads to exactly the voxels, geometry and orientation of
/// the uncompressed Philips series.
pub fn assert_same_volume(folder: &Path, what: &str) {
    let original = read_series(&data("dicom/philips_phantom_5mm"), &DicomOptions::default()).unwrap().volume;
    let copy = match read_series(folder, &DicomOptions::default()) {
        Ok(import) => import.volume,
        Err(error) => panic!("{what}: {error}"),
    };
    assert_eq!(copy.dims, [512, 512, 28], "{what}");
    assert_eq!(
        (copy.dims, copy.spacing_mm, copy.voxel_type),
        (original.dims, original.spacing_mm, original.voxel_type)
    );
    assert_eq!(copy.orientation, original.orientation, "{what}");
    let differing = copy.raw_bytes().iter().zip(original.raw_bytes()).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{what}: {differing} bytes differ from the uncompressed series");
}

#[test]
fn dcmtk_compressed_copies_read_to_the_uncompressed_voxels() {
    if !dcmtk_available() {
        return;
    }
    let root = tempfile::tempdir().unwrap();
    let tools: [(&str, &str, &[&str]); 4] = [
        ("jpeg-lossless-sv1", "dcmcjpeg", &["+e1"]),
        ("jpeg-ls-lossless", "dcmcjpls", &[]),
        ("rle-lossless", "dcmcrle", &[]),
        ("deflated", "dcmconv", &["+td"]),
    ];
    for (name, program, args) in tools {
        let folder = root.path().join(name);
        std::fs::create_dir(&folder).unwrap();
        for file in philips_files() {
            dcmtk(program, args, &file, &folder.join(file.file_name().unwrap()));
        }
        assert_same_volume(&folder, name);
    }
}

/// An item of a sequence holding one element.
fn item(element: DataElement<InMemDicomObject>) -> InMemDicomObject {
    InMemDicomObject::from_element_iter([element])
}

fn sequence(tag: Tag, items: Vec<InMemDicomObject>) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, VR::SQ, Value::from(DataSetSequence::from(items)))
}

/// The Philips series as one Enhanced CT file, frames in reverse slice order, written to `path`.
fn write_enhanced_ct(path: &Path) {
    let slices: Vec<InMemDicomObject> =
        philips_files().iter().rev().map(|file| dicom_object::open_file(file).unwrap().into_inner()).collect();
    let first = &slices[0];
    let copy = |object: &InMemDicomObject, tag: Tag| object.get(tag).unwrap().clone();
    let shared = InMemDicomObject::from_element_iter([
        sequence(
            tags::PIXEL_MEASURES_SEQUENCE,
            vec![InMemDicomObject::from_element_iter([
                copy(first, tags::PIXEL_SPACING),
                copy(first, tags::SLICE_THICKNESS),
            ])],
        ),
        sequence(tags::PLANE_ORIENTATION_SEQUENCE, vec![item(copy(first, tags::IMAGE_ORIENTATION_PATIENT))]),
        sequence(
            tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
            vec![InMemDicomObject::from_element_iter([
                copy(first, tags::RESCALE_INTERCEPT),
                copy(first, tags::RESCALE_SLOPE),
            ])],
        ),
    ]);
    let per_frame: Vec<InMemDicomObject> = slices
        .iter()
        .map(|slice| {
            item(sequence(tags::PLANE_POSITION_SEQUENCE, vec![item(copy(slice, tags::IMAGE_POSITION_PATIENT))]))
        })
        .collect();
    let mut pixels = Vec::new();
    for slice in &slices {
        pixels.extend(slice.get(tags::PIXEL_DATA).unwrap().to_bytes().unwrap().iter().copied());
    }
    let mut object = first.clone();
    for tag in [
        tags::PIXEL_SPACING,
        tags::SLICE_THICKNESS,
        tags::IMAGE_ORIENTATION_PATIENT,
        tags::IMAGE_POSITION_PATIENT,
        tags::RESCALE_INTERCEPT,
        tags::RESCALE_SLOPE,
    ] {
        object.remove_element(tag);
    }
    let enhanced_ct = "1.2.840.10008.5.1.4.1.1.2.1";
    object.put(DataElement::new(tags::SOP_CLASS_UID, VR::UI, enhanced_ct));
    object.put(DataElement::new(tags::SOP_INSTANCE_UID, VR::UI, "1.2.826.0.1.3680043.10.1.1"));
    object.put(DataElement::new(tags::SERIES_INSTANCE_UID, VR::UI, "1.2.826.0.1.3680043.10.1.2"));
    object.put(DataElement::new(tags::NUMBER_OF_FRAMES, VR::IS, slices.len().to_string()));
    object.put(sequence(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE, vec![shared]));
    object.put(sequence(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE, per_frame));
    object.put(DataElement::new(tags::PIXEL_DATA, VR::OB, PrimitiveValue::U8(C::from_vec(pixels))));
    object
        .with_meta(
            FileMetaTableBuilder::new()
                .transfer_syntax("1.2.840.10008.1.2.1")
                .media_storage_sop_class_uid(enhanced_ct)
                .media_storage_sop_instance_uid("1.2.826.0.1.3680043.10.1.1"),
        )
        .unwrap()
        .write_to_file(path)
        .unwrap();
}

#[test]
fn an_enhanced_ct_file_reads_as_its_single_frame_series() {
    let root = tempfile::tempdir().unwrap();
    let native = root.path().join("native");
    std::fs::create_dir(&native).unwrap();
    write_enhanced_ct(&native.join("enhanced.dcm"));
    assert_same_volume(&native, "enhanced CT, explicit VR little endian");
    let listed = list_series(&native, PatientShown::Hidden, &ReadLimits::default()).unwrap();
    assert_eq!(listed.len(), 1);
    assert_eq!((listed[0].images, listed[0].modality.as_str()), (28, "CT"));
    if !dcmtk_available() {
        return;
    }
    // `+fs 16`: frames split into fragments of at most 16 KB, found by the basic offset table.
    let cases: [(&str, &str, &[&str]); 3] =
        [("jpeg-ls", "dcmcjpls", &[]), ("jpeg-ls-fragments", "dcmcjpls", &["+fs", "16"]), ("rle", "dcmcrle", &[])];
    for (name, program, args) in cases {
        let folder = root.path().join(name);
        std::fs::create_dir(&folder).unwrap();
        dcmtk(program, args, &native.join("enhanced.dcm"), &folder.join("enhanced.dcm"));
        assert_same_volume(&folder, &format!("enhanced CT, {name}"));
    }
    // A frame header found through the offset table is checked like any other: the 28th
    // frame's (the last SOF55) claims 65535 x 65535 pixels.
    let mut bytes = std::fs::read(root.path().join("jpeg-ls-fragments/enhanced.dcm")).unwrap();
    let sof = bytes.windows(2).rposition(|pair| pair == [0xFF, 0xF7]).expect("a JPEG-LS frame header");
    bytes[sof + 5..sof + 9].copy_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF]);
    let lying = root.path().join("lying.dcm");
    std::fs::write(&lying, bytes).unwrap();
    let output = crate::support::volasso(&["info", lying.to_str().unwrap()], &root.path().join("cache"));
    crate::support::assert_clean_error(&output, "compressed as 65535 x 65535 pixels", "a lying fragmented frame");
    // One error for the file, not one per frame.
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(stderr.matches("compressed as").count(), 1, "{stderr}");
}

#[test]
fn a_folder_of_two_series_lists_both_for_a_picker_without_patient_data() {
    let root = tempfile::tempdir().unwrap();
    for series in ["philips_phantom_5mm", "ge_head_tilt"] {
        std::os::unix::fs::symlink(data(&format!("dicom/{series}")), root.path().join(series)).unwrap();
    }
    let listed = list_series(root.path(), PatientShown::Hidden, &ReadLimits::default()).unwrap();
    let brief: Vec<(usize, &str, bool)> =
        listed.iter().map(|s| (s.images, s.modality.as_str(), s.unreadable.is_none())).collect();
    assert_eq!(brief.len(), 2, "{listed:?}");
    assert!(brief.iter().all(|(images, modality, readable)| *images == 28 && *modality == "CT" && *readable));
    assert!(listed.iter().all(|summary| summary.patient.is_none() && !summary.series_uid.is_empty()));
    // Each opens by its UID, with every image listed.
    for summary in &listed {
        let options = DicomOptions { series_uid: Some(summary.series_uid.clone()), ..DicomOptions::default() };
        let import = read_series(root.path(), &options).unwrap();
        assert_eq!((import.series_uid.as_str(), import.files.len()), (summary.series_uid.as_str(), summary.images));
    }
}

#[test]
fn a_compressed_frame_that_declares_another_size_is_refused_before_decoding() {
    if !dcmtk_available() {
        return;
    }
    let root = tempfile::tempdir().unwrap();
    let compressed = root.path().join("jpeg-ls.dcm");
    dcmtk("dcmcjpls", &[], &data("dicom/philips_phantom_5mm/I10"), &compressed);
    let mut bytes = std::fs::read(&compressed).unwrap();
    // The JPEG-LS frame header (SOF55, FF F7): length, precision, then height and width.
    let sof = bytes.windows(2).position(|pair| pair == [0xFF, 0xF7]).expect("a JPEG-LS frame header");
    bytes[sof + 5..sof + 9].copy_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF]);
    let lying = root.path().join("lying.dcm");
    std::fs::write(&lying, bytes).unwrap();
    let output = crate::support::volasso(&["info", lying.to_str().unwrap()], &root.path().join("cache"));
    crate::support::assert_clean_error(&output, "compressed as 65535 x 65535 pixels", "a lying JPEG-LS header");
}

#[test]
fn dcmtk_12_bit_lossy_jpeg_reads_to_dcmtks_own_decoding() {
    if !dcmtk_available() {
        return;
    }
    let root = tempfile::tempdir().unwrap();
    let (lossy, decoded) = (root.path().join("jpeg-extended"), root.path().join("dcmdjpeg"));
    std::fs::create_dir(&lossy).unwrap();
    std::fs::create_dir(&decoded).unwrap();
    for file in philips_files() {
        let name = file.file_name().unwrap();
        dcmtk("dcmcjpeg", &["+ee"], &file, &lossy.join(name));
        dcmtk("dcmdjpeg", &[], &lossy.join(name), &decoded.join(name));
    }
    let ours = read_series(&lossy, &DicomOptions::default()).unwrap().volume;
    let dcmtks = read_series(&decoded, &DicomOptions::default()).unwrap().volume;
    assert_eq!((ours.dims, ours.voxel_type), ([512, 512, 28], dcmtks.voxel_type));
    let differing = ours.raw_bytes().iter().zip(dcmtks.raw_bytes()).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "the 12-bit JPEG Philips series differs from dcmdjpeg's decoding in {differing} bytes");
}

/// How a case of `scripts/pydicom_reference.py` must read: its voxels against pydicom's, and
/// the warnings the import gives (each a fragment of one warning, in order).
struct PydicomCase {
    name: &'static str,
    /// Lossy 12-bit JPEG: exactly dcmtk's voxels and within 2 of pydicom's (another IDCT:
    /// ISO 10918-2 allows each decoder 1 from the exact transform); otherwise exactly
    /// pydicom's.
    lossy_jpeg: bool,
    warnings: &'static [&'static str],
}

const NO_SPACING: &str = "PixelSpacing is missing: assuming 1 mm square pixels";
const UNPLACED: &str = "the 10 frames of";

const PYDICOM_CASES: [PydicomCase; 14] = [
    PydicomCase { name: "mlut_18", lossy_jpeg: false, warnings: &[NO_SPACING] },
    PydicomCase { name: "mlut_clipped_implicit", lossy_jpeg: false, warnings: &[NO_SPACING] },
    PydicomCase { name: "mlut_8bit_signed_implicit", lossy_jpeg: false, warnings: &[NO_SPACING] },
    PydicomCase { name: "explicit_VR-UN", lossy_jpeg: false, warnings: &[] },
    PydicomCase { name: "emri_small", lossy_jpeg: false, warnings: &[UNPLACED, NO_SPACING] },
    PydicomCase { name: "emri_small_RLE", lossy_jpeg: false, warnings: &[UNPLACED, NO_SPACING] },
    PydicomCase { name: "emri_small_big_endian", lossy_jpeg: false, warnings: &[UNPLACED, NO_SPACING] },
    PydicomCase { name: "emri_small_jpeg_2k_lossless", lossy_jpeg: false, warnings: &[UNPLACED, NO_SPACING] },
    PydicomCase { name: "emri_small_jpeg_ls_lossless", lossy_jpeg: false, warnings: &[UNPLACED, NO_SPACING] },
    PydicomCase { name: "JPGExtended", lossy_jpeg: true, warnings: &[] },
    PydicomCase {
        name: "JPEG-lossy",
        lossy_jpeg: true,
        warnings: &["the JPEG decoder warned \"Invalid SOS parameters for sequential JPEG\""],
    },
    PydicomCase { name: "dcmcjpeg_ee", lossy_jpeg: true, warnings: &[NO_SPACING] },
    PydicomCase {
        name: "MR_small_padded",
        lossy_jpeg: false,
        warnings: &["its PixelData ends in 128 bytes of zero padding after the image, ignored"],
    },
    PydicomCase {
        name: "CR_pixel_spacing_0",
        lossy_jpeg: false,
        warnings: &["PixelSpacing is 0 \\ 0 mm (0 means unknown): assuming 1 mm square pixels"],
    },
];

/// Little-endian float64 values as `scripts/pydicom_reference.py` writes them.
fn read_f64(path: &Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap_or_else(|error| panic!("{}: {error}", path.display()));
    bytes.chunks_exact(8).map(|chunk| f64::from_le_bytes(chunk.try_into().unwrap())).collect()
}

/// Files that pydicom decodes and this reader once refused or showed raw (a Modality LUT,
/// attributes stored as UN, padded PixelData, an enhanced MR without functional groups in five
/// syntaxes, 12-bit lossy JPEG, a PixelSpacing of 0), each read and compared voxel for voxel
/// with pydicom's decoding (`pixel_array`, then `apply_modality_lut`). pydicom's wheel ships
/// some; the script makes the rest with pydicom and dcmtk (see its doc). Needs python3 with
/// pydicom and its codec plugins, and dcmtk: `.ci/run` installs them, and this test fails
/// without them rather than pass untested.
#[test]
fn files_pydicom_decodes_read_to_pydicoms_voxels() {
    let out = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/pydicom_reference.py");
    let run = Command::new("python3").arg(&script).arg(out.path()).output().expect("python3 runs");
    assert!(
        run.status.success(),
        "{} failed (pydicom and its plugins: pip install pydicom pylibjpeg pylibjpeg-libjpeg pylibjpeg-openjpeg pyjpegls; dcmtk): {}",
        script.display(),
        String::from_utf8_lossy(&run.stderr)
    );
    let listing: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.path().join("cases.json")).unwrap()).unwrap();
    let listed: Vec<&str> =
        listing["cases"].as_array().unwrap().iter().map(|case| case["name"].as_str().unwrap()).collect();
    assert_eq!(listed, PYDICOM_CASES.iter().map(|case| case.name).collect::<Vec<_>>());
    // Every case is checked and every failure listed, not only the first.
    let mut failures = Vec::new();
    for case in PYDICOM_CASES {
        if let Err(failure) = check_pydicom_case(&case, out.path()) {
            failures.push(format!("{}: {failure}", case.name));
        }
    }
    assert!(failures.is_empty(), "{} of {} cases fail:\n{}", failures.len(), PYDICOM_CASES.len(), failures.join("\n"));
}

/// Reads one case and compares it with its references; the first difference found.
fn check_pydicom_case(case: &PydicomCase, out: &Path) -> Result<(), String> {
    let name = case.name;
    let import =
        read_series(&out.join(format!("{name}.dcm")), &DicomOptions::default()).map_err(|error| error.to_string())?;
    let volume = &import.volume;
    let [columns, rows, frames] = volume.dims;
    let ours: Vec<f64> = (0..frames)
        .flat_map(|z| (0..rows).flat_map(move |y| (0..columns).map(move |x| (x, y, z))))
        .map(|(x, y, z)| volume.value_at(x, y, z))
        .collect();
    let pydicoms = read_f64(&out.join(format!("{name}.pydicom.f64")));
    if ours.len() != pydicoms.len() {
        return Err(format!("{:?} voxels against pydicom's {}", volume.dims, pydicoms.len()));
    }
    // The volume keeps values that are not all int16 integers as float32, so pydicom's float64
    // values are compared rounded to float32.
    let apart = |reference: &[f64], tolerance: f64| {
        ours.iter().zip(reference).filter(|(a, b)| (**a - f64::from(**b as f32)).abs() > tolerance).count()
    };
    if case.lossy_jpeg {
        let dcmtks = read_f64(&out.join(format!("{name}.dcmtk.f64")));
        match (apart(&dcmtks, 0.0), apart(&pydicoms, 2.0)) {
            (0, 0) => {}
            (from_dcmtk, from_pydicom) => {
                return Err(format!(
                    "{from_dcmtk} voxels differ from dcmtk's decoding, {from_pydicom} are more than 2 from pydicom's"
                ));
            }
        }
    } else if apart(&pydicoms, 0.0) > 0 {
        return Err(format!("{} of {} voxels differ from pydicom's", apart(&pydicoms, 0.0), ours.len()));
    }
    let said = import.warnings.len() == case.warnings.len()
        && import.warnings.iter().zip(case.warnings).all(|(warning, expected)| warning.contains(expected));
    if !said {
        return Err(format!("warnings {:?}, expected {:?}", import.warnings, case.warnings));
    }
    Ok(())
}
