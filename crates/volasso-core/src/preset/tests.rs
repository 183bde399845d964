use super::*;
use crate::phantom::{self, Phantom, lassos_inside};

use crate::pipeline::{self, RunControl};
use crate::segmentation::{self, LabelVolume, SegmentationOptions};
use crate::strokes::TrainingSet;

/// Lassos inside each of `classes` that has room for one.
fn drawn(phantom: &Phantom, classes: &[u8]) -> crate::strokes::StrokesFile {
    let mut strokes = lassos_inside(phantom, classes, 2, 1.5);
    strokes.classes.retain(|class| !class.strokes.is_empty());
    strokes
}

/// The head MRI phantom's classes 1..=last drawn with lassos inside them, classified, and its
/// preset; with the labels.
fn head_and_preset(phantom: &Phantom, modality: Modality) -> (Preset, LabelVolume) {
    let classes: Vec<u8> = (1..phantom.class_names.len() as u8).collect();
    let strokes = drawn(phantom, &classes);
    let training = TrainingSet::from_strokes(&strokes, phantom.volume.dims).unwrap();
    let options = SegmentationOptions::default();
    let (segmenter, labels) =
        pipeline::classify_training(&phantom.volume, &training, &options, RunControl::batch()).unwrap();
    let names: Vec<String> = strokes.classes.iter().map(|class| class.name.clone()).collect();
    let table =
        ClassTable::compute(&phantom.volume, &labels.labels, names.len(), HueTemplate::default_for(names.len()))
            .unwrap();
    (Preset::of("head", &segmenter, &phantom.volume, modality, &names, &table).unwrap(), labels)
}

fn applied(preset: &Preset, volume: &Volume, modality: Modality) -> Result<LabelVolume, PresetError> {
    let samples = preset.samples_for(volume, modality)?;
    let options = SegmentationOptions::default();
    Ok(pipeline::classify_samples(volume, samples, &options, RunControl::batch()).unwrap().1)
}

/// The share of the voxels `b` classifies that `a` labels the same.
fn agreement(a: &[u8], b: &[u8]) -> f64 {
    let classified = b.iter().filter(|&&label| label != 0).count();
    a.iter().zip(b).filter(|&(x, y)| x == y && *y != 0).count() as f64 / classified as f64
}

/// `volume`'s values mapped by `value` into a float volume of the same geometry.
fn remapped(volume: &Volume, value: impl Fn(usize, f64) -> f32) -> Volume {
    let values: Vec<f32> = (0..volume.voxel_count()).map(|i| value(i, volume.value(i))).collect();
    Volume::from_f32(volume.dims, volume.spacing_mm, &values, Path::new("<remapped>")).unwrap()
}

#[test]
fn a_preset_applied_to_its_own_scan_gives_its_labels_and_survives_a_round_trip() {
    let phantom = phantom::bodies::head_mri([64, 72, 68], 3).unwrap();
    let (preset, labels) = head_and_preset(&phantom, Modality::Mr);
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("head.volasso-preset");
    preset.write(&path).unwrap();
    let read = Preset::read(&path).unwrap();
    assert_eq!(read, preset);
    let again = applied(&read, &phantom.volume, Modality::Mr).unwrap();
    assert!(agreement(&again.labels, &labels.labels) > 0.995, "{}", agreement(&again.labels, &labels.labels));
}

/// The failure a standard scale prevents: an MRI of the same anatomy with another receiver
/// gain and offset has other numbers for the same tissue.
#[test]
fn a_preset_classifies_an_mri_with_another_gain_and_offset_the_same() {
    let phantom = phantom::bodies::head_mri([64, 72, 68], 3).unwrap();
    let (preset, labels) = head_and_preset(&phantom, Modality::Mr);
    let brighter = remapped(&phantom.volume, |_, v| (1.8 * v + 40.0) as f32);
    let again = applied(&preset, &brighter, Modality::Mr).unwrap();
    assert!(agreement(&again.labels, &labels.labels) > 0.99, "{}", agreement(&again.labels, &labels.labels));
    // Vectors kept in the first scan's own units would not.
    let mut raw = preset.samples_for(&phantom.volume, Modality::Mr).unwrap();
    raw.background = preset.samples_for(&brighter, Modality::Mr).unwrap().background;
    let options = SegmentationOptions::default();
    let wrong = pipeline::classify_samples(&brighter, raw, &options, RunControl::batch()).unwrap().1;
    assert!(agreement(&wrong.labels, &labels.labels) < 0.9, "{}", agreement(&wrong.labels, &labels.labels));
}

#[test]
fn a_preset_of_one_modality_refuses_a_scan_of_the_other() {
    let phantom = phantom::bodies::head_mri([48, 54, 50], 3).unwrap();
    let (preset, _) = head_and_preset(&phantom, Modality::Mr);
    let error = preset.samples_for(&phantom.volume, Modality::Ct).unwrap_err();
    assert!(matches!(error, PresetError::Modality { preset: "MR", scan: "CT", .. }), "{error}");
    assert!(error.to_string().contains("trained on MR and this scan is CT"), "{error}");
    // Unknown on either side is not a refusal.
    assert!(preset.samples_for(&phantom.volume, Modality::Unknown).is_ok());
}

#[test]
fn a_hounsfield_preset_refuses_a_ct_that_is_not_in_hounsfield_units() {
    let foot = phantom::demo_foot();
    let classes: Vec<u8> = (1..foot.class_names.len() as u8).collect();
    let strokes = drawn(&foot, &classes);
    let training = TrainingSet::from_strokes(&strokes, foot.volume.dims).unwrap();
    let segmenter = segmentation::train(&foot.volume, &training, &SegmentationOptions::default()).unwrap();
    let names: Vec<String> = strokes.classes.iter().map(|class| class.name.clone()).collect();
    let labels = vec![0u8; foot.volume.voxel_count()];
    let table = ClassTable::compute(&foot.volume, &labels, names.len(), HueTemplate::default_for(names.len())).unwrap();
    let preset = Preset::of("foot", &segmenter, &foot.volume, Modality::Ct, &names, &table).unwrap();
    assert_eq!(preset.scale, StandardScale::Hounsfield);
    // A windowed 8-bit export of the same CT.
    let windowed = remapped(&foot.volume, |_, v| ((v + 1000.0) / 8.0).clamp(0.0, 255.0) as f32);
    let error = preset.samples_for(&windowed, Modality::Ct).unwrap_err();
    assert!(matches!(error, PresetError::NotHounsfield { .. }), "{error}");
    let unknown = preset.samples_for(&windowed, Modality::Unknown).unwrap_err();
    assert!(unknown.to_string().contains("say it is a CT"), "{unknown}");
}

#[test]
fn a_damaged_or_foreign_preset_file_is_refused_with_its_reason() {
    let phantom = phantom::bodies::head_mri([48, 54, 50], 3).unwrap();
    let (preset, _) = head_and_preset(&phantom, Modality::Mr);
    let folder = tempfile::tempdir().unwrap();
    let text = preset.to_json().unwrap();
    let write = |name: &str, text: &str| {
        let path = folder.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let truncated = write("cut.volasso-preset", &text[..text.len() / 2]);
    assert!(matches!(Preset::read(&truncated), Err(PresetError::Damaged { .. })));
    let newer = write("newer.volasso-preset", &text.replace(PRESET_FORMAT, "volasso-preset/2"));
    let error = Preset::read(&newer).unwrap_err();
    assert!(matches!(&error, PresetError::Version { found, .. } if found == "volasso-preset/2"), "{error}");
    let strokes = write("strokes.json", r#"{"format": "volasso-strokes/1", "classes": []}"#);
    assert!(matches!(Preset::read(&strokes), Err(PresetError::Damaged { .. })));
    let mut short = preset.clone();
    short.samples[0].features.pop();
    let short = write("short.volasso-preset", &short.to_json().unwrap());
    let error = Preset::read(&short).unwrap_err();
    assert!(error.to_string().contains("training vector 0"), "{error}");
    let mut empty_class = preset.clone();
    empty_class.samples.retain(|sample| sample.class != 1);
    let empty_class = write("empty.volasso-preset", &empty_class.to_json().unwrap());
    assert!(Preset::read(&empty_class).unwrap_err().to_string().contains("no training vector"));
}

#[test]
fn loops_drawn_on_the_new_scan_join_the_preset_by_class_name() {
    let preset = ["bone".to_string(), "muscle".to_string()];
    let drawn = ["fat".to_string(), "bone".to_string()];
    let (names, ids) = joined_classes(&preset, &drawn);
    assert_eq!(names, ["bone", "muscle", "fat"]);
    assert_eq!(ids, [3, 1]);
}

#[test]
fn a_loop_added_to_a_preset_changes_the_classification() {
    let phantom = phantom::bodies::head_mri([48, 54, 50], 3).unwrap();
    let (mut preset, _) = head_and_preset(&phantom, Modality::Mr);
    // The preset without its last class; the loops drawn for it on the scan bring it back.
    let last = preset.classes.len() as u8;
    preset.classes.pop();
    preset.samples.retain(|sample| sample.class != last);
    preset.bands = preset.bands.map(|mut bands| {
        bands.pop();
        bands
    });
    let options = SegmentationOptions::default();
    let without = preset.samples_for(&phantom.volume, Modality::Mr).unwrap();
    let without = pipeline::classify_samples(&phantom.volume, without, &options, RunControl::batch()).unwrap().1;
    let name = &preset_names_before(&phantom)[last as usize - 1];
    let class = phantom.class_names.iter().position(|known| known == name).unwrap() as u8;
    let strokes = drawn(&phantom, &[class]);
    let training = TrainingSet::from_strokes(&strokes, phantom.volume.dims).unwrap();
    let (samples, names) =
        pipeline::preset_samples(&phantom.volume, &preset, Modality::Mr, Some(&training), &options).unwrap();
    assert_eq!(names.last(), Some(name));
    let with = pipeline::classify_samples(&phantom.volume, samples, &options, RunControl::batch()).unwrap().1;
    let in_new_class = with.labels.iter().filter(|&&label| label == last).count();
    assert!(without.labels.iter().all(|&label| label < last));
    let truth_count = phantom.truth.iter().filter(|&&truth| truth == class).count();
    assert!(in_new_class * 2 > truth_count, "{in_new_class} of {truth_count}");
}

/// The names of the head phantom's classes that have room for a lasso, in class order.
fn preset_names_before(phantom: &Phantom) -> Vec<String> {
    let classes: Vec<u8> = (1..phantom.class_names.len() as u8).collect();
    drawn(phantom, &classes).classes.into_iter().map(|class| class.name).collect()
}

#[test]
fn a_preset_keeps_only_the_classes_a_user_left() {
    let phantom = phantom::bodies::head_mri([48, 54, 50], 3).unwrap();
    let (preset, _) = head_and_preset(&phantom, Modality::Mr);
    let names = preset.class_names();
    let left = [names[2].clone(), names[0].clone()];
    let only = preset.only(&left).unwrap();
    assert_eq!(only.class_names(), [names[0].clone(), names[2].clone()]);
    let count = |p: &Preset, class: u8| p.samples.iter().filter(|s| s.class == class).count();
    assert_eq!((count(&only, 1), count(&only, 2)), (count(&preset, 1), count(&preset, 3)));
    assert!(only.samples.iter().all(|s| (1..=2).contains(&s.class)));
    assert!(preset.only(&["none of them".to_string()]).is_none());
}
