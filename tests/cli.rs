//! The `volasso` binary's contracts (`interfaces.md`): output, exit codes, atomic writes.

use crate::support::{data, volasso};

#[test]
fn info_json_reports_geometry_and_a_small_anonymous_footprint() {
    let cache = tempfile::tempdir().unwrap();
    let output = volasso(&["info", data("engine_256x256x256_uint8.raw").to_str().unwrap(), "--json"], cache.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let info: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(info["dims"], serde_json::json!([256, 256, 256]));
    assert_eq!(info["type"], "uint8");
    assert_eq!(info["memory_mapped"], true);
    // The 16 MiB volume is mapped, not copied: anonymous memory stays far below its size.
    let anonymous = info["resident_memory"]["anonymous_bytes"].as_u64().unwrap();
    assert!(anonymous < 8 << 20, "anonymous resident memory {anonymous} bytes");
}

#[test]
fn import_writes_a_mappable_nrrd_and_replaces_it_atomically() {
    let folder = tempfile::tempdir().unwrap();
    let out = folder.path().join("tooth.nrrd");
    let output =
        volasso(&["import", data("tooth.nrrd").to_str().unwrap(), "--out", out.to_str().unwrap()], folder.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let imported = volasso::volume::open(&out, &Default::default()).unwrap();
    let original = volasso::volume::open(&data("tooth.nrrd"), &Default::default()).unwrap();
    assert_eq!(imported.raw_bytes(), original.raw_bytes());
    assert!(imported.is_memory_mapped());

    // A failing import leaves the existing output as it was and no temporary files behind.
    let before = std::fs::read(&out).unwrap();
    let bad = folder.path().join("bad_2x2x2_uint8.raw");
    std::fs::write(&bad, [0u8; 3]).unwrap();
    let output = volasso(&["import", bad.to_str().unwrap(), "--out", out.to_str().unwrap()], folder.path());
    assert!(!output.status.success());
    assert_eq!(std::fs::read(&out).unwrap(), before);
    let leftovers: Vec<_> = std::fs::read_dir(folder.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn render_classifies_and_writes_a_png_of_the_requested_size() {
    let folder = tempfile::tempdir().unwrap();
    let out = folder.path().join("demo.png");
    let strokes = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/strokes/demo-foot.strokes.json");
    let output = volasso(
        &["render", "demo", "--strokes", strokes, "--out", out.to_str().unwrap(), "--size", "160x120"],
        folder.path(),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let image = image::open(&out).unwrap().to_rgba8();
    assert_eq!(image.dimensions(), (160, 120));
    // The foot fills part of the frame: some pixels are lit, the corners are background.
    let lit = image.pixels().filter(|p| p.0[0] as u32 + p.0[1] as u32 + p.0[2] as u32 > 120).count();
    assert!(lit > 160 * 120 / 20 && lit < 160 * 120 * 3 / 4, "{lit} lit pixels");
}

#[test]
fn info_json_gives_anatomical_axes_or_null_and_import_keeps_them() {
    let folder = tempfile::tempdir().unwrap();
    let info = |path: &str| -> serde_json::Value {
        let output = volasso(&["info", path, "--json"], folder.path());
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        serde_json::from_slice(&output.stdout).unwrap()
    };
    let nifti = data("anatomical.nii");
    assert_eq!(info(nifti.to_str().unwrap())["anatomical_axes"], serde_json::json!(["L", "A", "S"]));
    assert_eq!(
        info(data("dicom/ge_head_tilt").to_str().unwrap())["anatomical_axes"],
        serde_json::json!(["L", "P", "S"])
    );
    assert_eq!(
        info(data("lobster_301x324x56_uint8.raw").to_str().unwrap())["anatomical_axes"],
        serde_json::Value::Null
    );
    // `import` writes the orientation as an LPS space; the NRRD reads back with the same axes.
    let out = folder.path().join("anatomical.nrrd");
    let output = volasso(&["import", nifti.to_str().unwrap(), "--out", out.to_str().unwrap()], folder.path());
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let header = String::from_utf8_lossy(&std::fs::read(&out).unwrap()[..400]).into_owned();
    assert!(
        header.contains(
            "space: left-posterior-superior\nspace directions: (2,0,0) (0,-2,0) (0,0,2)\nspace origin: (-32,40,-16)\n"
        ),
        "{header}"
    );
    assert_eq!(info(out.to_str().unwrap())["anatomical_axes"], serde_json::json!(["L", "A", "S"]));
}
