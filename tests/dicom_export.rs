//! `volasso export`: the Philips series classified from two lassos becomes a DICOM
//! Segmentation and a Secondary Capture that dicom3tools' `dciodvfy` validates without an error,
//! and highdicom (`scripts/seg_highdicom.py`, the reader behind Slicer's and OHIF's DICOM SEG
//! support in Python) reads back voxel for voxel equal to the labels, with the classes' names
//! and colours. Labels of a NRRD, of other dimensions, or with a class table that does not
//! match are refused with one error and nothing written. Without dciodvfy or highdicom the
//! checks that need them say so and are skipped (`.ci/run` installs both).

use crate::support::{assert_clean_error, data, volasso};
use dicom_dictionary_std::tags::{FRAME_OF_REFERENCE_UID, SERIES_INSTANCE_UID, STUDY_INSTANCE_UID};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The Philips CT series (28 slices of 512 x 512).
pub fn philips() -> PathBuf {
    data("dicom/philips_phantom_5mm")
}

/// Two classes lassoed on slices 10 and 16 of the Philips series: the dense insert and the
/// foam above it.
pub const PHILIPS_STROKES: &str = r#"{"format": "volasso-strokes/1", "classes": [
 {"name": "insert", "strokes": [{"axis": "z", "slice": 10, "points": [[200, 262], [310, 262], [310, 300], [200, 300]]},
                                {"axis": "z", "slice": 16, "points": [[200, 262], [310, 262], [310, 300], [200, 300]]}]},
 {"name": "foam", "strokes": [{"axis": "z", "slice": 10, "points": [[200, 170], [310, 170], [310, 195], [200, 195]]},
                              {"axis": "z", "slice": 16, "points": [[200, 170], [310, 170], [310, 195], [200, 195]]}]}
]}"#;

/// Classifies the Philips series into `folder/labels.nrrd` (and its class table).
pub fn classify_philips(folder: &Path) -> PathBuf {
    classify_series(folder, &philips())
}

/// Classifies `series` (a copy of the Philips series) with [`PHILIPS_STROKES`] into
/// `folder/labels.nrrd`.
pub fn classify_series(folder: &Path, series: &Path) -> PathBuf {
    let strokes = folder.join("strokes.json");
    std::fs::write(&strokes, PHILIPS_STROKES).unwrap();
    let labels = folder.join("labels.nrrd");
    let cache = folder.join("cache");
    let output = volasso(
        &[
            "classify",
            series.to_str().unwrap(),
            "--strokes",
            strokes.to_str().unwrap(),
            "--out",
            labels.to_str().unwrap(),
        ],
        &cache,
    );
    assert!(output.status.success(), "classify: {}", String::from_utf8_lossy(&output.stderr));
    labels
}

/// Runs `volasso export` on the Philips series.
pub(crate) fn export(folder: &Path, source: &Path, labels: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["export", source.to_str().unwrap(), "--labels", labels.to_str().unwrap()];
    args.extend_from_slice(extra);
    volasso(&args, &folder.join("cache"))
}

/// `dciodvfy`'s complaints about `file` that are errors (its warnings are listed but allowed),
/// or `None` when dicom3tools is not installed.
pub fn dciodvfy_errors(file: &Path) -> Option<Vec<String>> {
    let output = match Command::new("dciodvfy").arg(file).output() {
        Ok(output) => output,
        Err(_) => {
            eprintln!("SKIPPED: dciodvfy is not installed (apt-get install dicom3tools; .ci/run installs it)");
            return None;
        }
    };
    let text = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    eprintln!("dciodvfy {}:\n{text}", file.display());
    Some(text.lines().filter(|line| line.starts_with("Error")).map(str::to_string).collect())
}

/// Whether Python can import highdicom (pip install highdicom; `.ci/run` installs it).
pub fn highdicom_available() -> bool {
    let found = Command::new("python3").args(["-c", "import highdicom"]).output().is_ok_and(|o| o.status.success());
    if !found {
        eprintln!("SKIPPED: highdicom is not installed (pip install highdicom; .ci/run installs it)");
    }
    found
}

/// What `scripts/seg_highdicom.py` read from `seg`.
pub fn read_with_highdicom(seg: &Path, series: &Path, labels: &Path) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/seg_highdicom.py");
    let output = Command::new("python3").arg(script).arg(seg).arg(series).arg(labels).output().unwrap();
    assert!(output.status.success(), "highdicom cannot read the SEG: {}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).unwrap()
}

/// A DICOM file's value of an attribute as text, to compare UIDs.
pub fn attribute(file: &Path, tag: dicom_core::Tag) -> String {
    let object = dicom_object::open_file(file).unwrap();
    object.element(tag).unwrap().to_str().unwrap().trim_end_matches('\0').to_string()
}

#[test]
fn a_classified_dicom_series_exports_as_a_valid_seg_and_sc_that_highdicom_reads_back_voxel_for_voxel() {
    let folder = tempfile::tempdir().unwrap();
    let labels = classify_philips(folder.path());
    let (seg, sc) = (folder.path().join("out.seg.dcm"), folder.path().join("out.sc.dcm"));
    let output = export(
        folder.path(),
        &philips(),
        &labels,
        &["--seg", seg.to_str().unwrap(), "--sc", sc.to_str().unwrap(), "--size", "320x240"],
    );
    assert!(output.status.success(), "export: {}", String::from_utf8_lossy(&output.stderr));
    let line: serde_json::Value = serde_json::from_slice(&output.stdout).expect("one JSON line");
    assert_eq!(line["segments"], 2, "{line}");

    // Both objects join the source's study in series of their own.
    let source = philips().join("I10");
    let study = attribute(&source, STUDY_INSTANCE_UID);
    for file in [&seg, &sc] {
        assert_eq!(attribute(file, STUDY_INSTANCE_UID), study, "{}", file.display());
        assert_ne!(attribute(file, SERIES_INSTANCE_UID), attribute(&source, SERIES_INSTANCE_UID), "{}", file.display());
    }
    assert_ne!(attribute(&seg, SERIES_INSTANCE_UID), attribute(&sc, SERIES_INSTANCE_UID));
    assert_eq!(
        attribute(&seg, FRAME_OF_REFERENCE_UID),
        attribute(&source, FRAME_OF_REFERENCE_UID),
        "frame of reference"
    );
    assert_eq!(line["seg_series_uid"].as_str(), Some(attribute(&seg, SERIES_INSTANCE_UID).as_str()));

    for file in [&seg, &sc] {
        if let Some(errors) = dciodvfy_errors(file) {
            assert!(errors.is_empty(), "dciodvfy finds errors in {}: {errors:?}", file.display());
        }
    }
    if !highdicom_available() {
        return;
    }
    let read = read_with_highdicom(&seg, &philips(), &labels);
    assert_eq!(read["shape"], serde_json::json!([28, 512, 512]), "{read}");
    assert_eq!(read["differing_voxels"], 0, "the SEG differs from the labels: {read}");
    assert_eq!(read["study_uid"].as_str(), Some(study.as_str()));
    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(folder.path().join("labels.classes.json")).unwrap()).unwrap();
    let segments = read["segments"].as_array().unwrap();
    assert_eq!(segments.len(), 2, "{read}");
    for (index, (segment, name)) in segments.iter().zip(["insert", "foam"]).enumerate() {
        assert_eq!(segment["number"], index + 1);
        assert_eq!(segment["label"], name, "{read}");
        // Every class holds voxels, as many as the class table counts.
        assert_eq!(read["voxels_per_segment"][(index + 1).to_string()], table["voxel_counts"][index], "{read}");
        assert!(table["voxel_counts"][index].as_u64().unwrap() > 1000, "{table}");
        // The colour: the class's HSV from the table, through highdicom's CIELab decoding.
        let style = &table["styles"][index];
        let rgb = volasso::transfer::hsv_to_rgb(
            style["hue_degrees"][0].as_f64().unwrap() as f32,
            style["saturation"].as_f64().unwrap() as f32,
            style["value"].as_f64().unwrap() as f32,
        );
        for (channel, expected) in rgb.iter().enumerate() {
            let got = segment["rgb"][channel].as_i64().unwrap();
            let expected = (expected * 255.0).round() as i64;
            assert!((got - expected).abs() <= 1, "segment {name} channel {channel}: {got} against {expected}: {read}");
        }
    }
}

#[test]
fn labels_that_do_not_belong_to_the_series_are_refused_and_nothing_is_written() {
    let folder = tempfile::tempdir().unwrap();
    let labels = classify_philips(folder.path());
    let seg = folder.path().join("refused.dcm");
    let seg_args = ["--seg", seg.to_str().unwrap()];

    // A volume that is not DICOM has no study to join.
    let output = export(folder.path(), &data("tooth.nrrd"), &labels, &seg_args);
    assert_clean_error(&output, "only a DICOM series", "NRRD source");

    // Labels of other dimensions.
    let small = folder.path().join("small.nrrd");
    let mut bytes = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n".to_vec();
    bytes.extend([0, 1, 1, 0, 2, 2, 0, 0]);
    std::fs::write(&small, bytes).unwrap();
    std::fs::copy(folder.path().join("labels.classes.json"), folder.path().join("small.classes.json")).unwrap();
    let output = export(folder.path(), &philips(), &small, &seg_args);
    assert_clean_error(&output, "do not belong together", "labels of other dimensions");

    // A class table whose counts are another classification's.
    let table_path = folder.path().join("labels.classes.json");
    let original = std::fs::read_to_string(&table_path).unwrap();
    let mut table: serde_json::Value = serde_json::from_str(&original).unwrap();
    table["voxel_counts"][0] = serde_json::json!(table["voxel_counts"][0].as_u64().unwrap() + 1);
    std::fs::write(&table_path, table.to_string()).unwrap();
    let output = export(folder.path(), &philips(), &labels, &seg_args);
    assert_clean_error(&output, "class table does not match", "voxel counts differ");

    // A class table without class names (older tables), and one with a class too few.
    let mut table: serde_json::Value = serde_json::from_str(&original).unwrap();
    table.as_object_mut().unwrap().remove("classes");
    std::fs::write(&table_path, table.to_string()).unwrap();
    let output = export(folder.path(), &philips(), &labels, &seg_args);
    assert_clean_error(&output, "names no classes", "no class names");
    let mut table: serde_json::Value = serde_json::from_str(&original).unwrap();
    for field in ["classes", "styles", "voxel_counts"] {
        table[field].as_array_mut().unwrap().pop();
    }
    std::fs::write(&table_path, table.to_string()).unwrap();
    let output = export(folder.path(), &philips(), &labels, &seg_args);
    assert_clean_error(&output, "the labels hold class 2", "a class beyond the table");

    // A table from another run than the labels.
    let mut table: serde_json::Value = serde_json::from_str(&original).unwrap();
    table["run"] = serde_json::json!("1-1");
    std::fs::write(&table_path, table.to_string()).unwrap();
    let output = export(folder.path(), &philips(), &labels, &seg_args);
    assert_clean_error(&output, "written by run 1-1", "another run");

    assert!(!seg.exists(), "a refused export wrote its output");
    std::fs::write(&table_path, original).unwrap();
    let output = export(folder.path(), &philips(), &labels, &seg_args);
    assert!(output.status.success(), "the untouched table exports: {}", String::from_utf8_lossy(&output.stderr));
    assert!(seg.exists());
}
