use super::*;
use crate::autosave::SavedLook;
use volasso_core::render::ClipPlane;
use volasso_core::slices::Axis;
use volasso_core::strokes::{ClassStrokes, Lasso, StrokesFile};

fn entry(volume: &str, saved_unix: u64) -> GalleryEntry {
    let lasso = Lasso { axis: Axis::Z, slice: 3, points: vec![[1.0, 2.0], [7.5, 2.0], [7.5, 9.0]] };
    GalleryEntry {
        session: SavedSession {
            volume: volume.into(),
            template: "T".into(),
            rotation_degrees: 12.0,
            strokes: StrokesFile { classes: vec![ClassStrokes { name: "Class 1".into(), strokes: vec![lasso] }] },
            look: SavedLook {
                class_opacity: [("Class 1".to_string(), 0.25)].into_iter().collect(),
                clip: Some(ClipPlane { normal: [0.0, 0.6, 0.8], offset_mm: -4.5 }),
                preset: None,
            },
        },
        volume_name: "foot".into(),
        saved_unix,
        camera: Camera {
            azimuth_degrees: 75.0,
            elevation_degrees: -10.0,
            zoom: 1.5,
            pan_mm: [3.0, -2.0],
            ..Camera::default()
        },
        visible: vec![true, false],
    }
}

fn picture(width: u32, height: u32) -> image::RgbaImage {
    image::RgbaImage::from_fn(width, height, |x, y| image::Rgba([(x % 256) as u8, (y % 256) as u8, 90, 255]))
}

#[test]
fn a_kept_result_comes_back_whole_with_a_small_thumbnail() {
    let data = tempfile::tempdir().unwrap();
    let kept = entry("demo", 1_700_000_000);
    let folder = save(data.path(), &kept, &picture(800, 400)).unwrap();
    assert_eq!(folder, data.path().join("gallery/result-1700000000"));
    let listed = list(data.path());
    assert_eq!(listed.len(), 1);
    let Listed::Entry { entry, thumbnail, .. } = &listed[0] else { panic!("{listed:?}") };
    assert_eq!(**entry, kept);
    assert!(!entry.volume_missing());
    assert_eq!(thumbnail.as_ref().map(|t| t.dimensions()), Some((256, 128)));
    // The session inside is the autosave record, readable as one.
    let text = std::fs::read_to_string(folder.join("entry.json")).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(autosave::from_record(value["session"].clone()).unwrap(), kept.session);
}

#[test]
fn saves_in_the_same_second_never_overwrite_each_other_and_list_newest_first() {
    let data = tempfile::tempdir().unwrap();
    save(data.path(), &entry("demo", 100), &picture(10, 10)).unwrap();
    let second = save(data.path(), &entry("demo", 100), &picture(10, 10)).unwrap();
    assert_eq!(second.file_name().unwrap(), "result-100-1");
    save(data.path(), &entry("demo", 200), &picture(10, 10)).unwrap();
    let saved: Vec<u64> = list(data.path())
        .iter()
        .map(|listed| match listed {
            Listed::Entry { entry, .. } => entry.saved_unix,
            Listed::Damaged { reason, .. } => panic!("{reason}"),
        })
        .collect();
    assert_eq!(saved, [200, 100, 100]);
}

#[test]
fn damaged_entries_are_listed_with_a_reason_and_a_missing_volume_is_named() {
    let data = tempfile::tempdir().unwrap();
    let good = save(data.path(), &entry("demo", 10), &picture(10, 10)).unwrap();
    let text = std::fs::read_to_string(good.join("entry.json")).unwrap();
    let gallery = gallery_dir(data.path());
    let write = |name: &str, file: &str, bytes: &[u8]| {
        std::fs::create_dir_all(gallery.join(name)).unwrap();
        std::fs::write(gallery.join(name).join(file), bytes).unwrap();
    };
    write("result-1", "entry.json", &text.as_bytes()[..text.len() / 2]);
    write("result-2", "entry.json", text.replace(GALLERY_FORMAT, "other/9").as_bytes());
    write("result-3", "thumbnail.png", b"\x89PNG not really");
    write("result-4", "entry.json", text.as_bytes());
    write("result-4", "thumbnail.png", b"\x89PNG\r\n\x1a\n garbage");
    let missing = data.path().join("gone.nrrd");
    write(
        "result-5",
        "entry.json",
        text.replace("\"demo\"", &format!("{:?}", missing.display().to_string())).as_bytes(),
    );
    let listed = list(data.path());
    let reasons: Vec<String> = listed
        .iter()
        .filter_map(|listed| match listed {
            Listed::Damaged { reason, .. } => Some(reason.clone()),
            Listed::Entry { .. } => None,
        })
        .collect();
    assert_eq!(reasons.len(), 4, "{reasons:?}");
    assert!(reasons.iter().any(|r| r.starts_with("the entry is not valid JSON")), "{reasons:?}");
    assert!(reasons.iter().any(|r| r.contains("format 'other/9'")), "{reasons:?}");
    assert!(reasons.iter().any(|r| r == "the entry is incomplete (no entry.json)"), "{reasons:?}");
    assert!(reasons.iter().any(|r| r.starts_with("the thumbnail is not a usable PNG")), "{reasons:?}");
    let missing_entry = listed.iter().find_map(|listed| match listed {
        Listed::Entry { entry, .. } if entry.volume_missing() => Some(entry.clone()),
        _ => None,
    });
    assert_eq!(missing_entry.unwrap().missing_message(), "The scan this result needs is missing: foot");
}

#[test]
fn a_lying_camera_is_brought_into_range() {
    let data = tempfile::tempdir().unwrap();
    let folder = save(data.path(), &entry("demo", 10), &picture(4, 4)).unwrap();
    let path = folder.join("entry.json");
    let mut value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    value["camera"]["zoom"] = serde_json::json!(1e30);
    value["camera"]["elevation_degrees"] = serde_json::json!(-400.0);
    std::fs::write(&path, value.to_string()).unwrap();
    let (entry, _) = read(&folder).unwrap();
    assert_eq!(entry.camera.zoom, 8.0);
    assert_eq!(entry.camera.elevation_degrees, -89.0);
}

#[test]
fn dates_are_utc_calendar_days() {
    assert_eq!(date_text(0), "1970-01-01 00:00");
    assert_eq!(date_text(951_782_400), "2000-02-29 00:00");
    assert_eq!(date_text(1_796_169_000), "2026-12-01 23:50");
}
