//! Pictures of real volumes for looking at: grey slices to draw lassos on, then slice
//! overlays and a z-composited RGBA projection from a label NRRD made by `volasso classify`.
//! Ignored by default (they need labels made beforehand); run with
//! `VOLASSO_PICTURES=DIR VOLASSO_VOLUME=V VOLASSO_STROKES=S.json cargo test --lib pictures -- --ignored`
//! (or `VOLASSO_LABELS=L.nrrd` instead of the strokes to use labels made beforehand).

use super::*;
use crate::segmentation::{SegmentationOptions, label_volume, train};
use crate::slices::{Axis, DisplayWindow};
use crate::strokes::{StrokesFile, TrainingSet};
use crate::volume::open::{OpenOptions, open};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

fn env_path(name: &str) -> PathBuf {
    PathBuf::from(std::env::var(name).unwrap_or_else(|_| panic!("set {name}")))
}

fn middle_slices(dims: [usize; 3]) -> [(Axis, usize); 3] {
    [(Axis::Z, dims[2] / 2), (Axis::Y, dims[1] / 2), (Axis::X, dims[0] / 2)]
}

#[test]
#[ignore]
fn grey_slices_for_drawing_lassos() {
    let folder = env_path("VOLASSO_PICTURES");
    let volume = open(&env_path("VOLASSO_VOLUME"), &OpenOptions::default()).unwrap();
    let window = DisplayWindow::automatic(&volume);
    let labels = vec![0u8; volume.voxel_count()];
    for (axis, slice) in middle_slices(volume.dims) {
        let image = slice_overlay(&volume, &labels, &[], axis, slice, window, 0.0).unwrap();
        write_png(&folder.join(format!("grey_{axis}{slice}.png")), &image).unwrap();
    }
}

#[test]
#[ignore]
fn overlays_and_rgba_projection_of_a_classified_volume() {
    let folder = env_path("VOLASSO_PICTURES");
    let volume = open(&env_path("VOLASSO_VOLUME"), &OpenOptions::default()).unwrap();
    let labels = match std::env::var("VOLASSO_LABELS") {
        Ok(path) => open(Path::new(&path), &OpenOptions::default()).unwrap().raw_bytes().to_vec(),
        // No labels given: classify here from the strokes, as `volasso classify` does.
        Err(_) => {
            let strokes = StrokesFile::read_for_volume(&env_path("VOLASSO_STROKES"), volume.dims).unwrap();
            let training = TrainingSet::from_strokes(&strokes, volume.dims).unwrap();
            let options = SegmentationOptions::default();
            let segmenter = train(&volume, &training, &options).unwrap();
            let cancel = AtomicBool::new(false);
            label_volume(&volume, &segmenter, options.refinement, &|_| {}, &cancel).unwrap().labels
        }
    };
    assert_eq!(labels.len(), volume.voxel_count());
    let class_count = *labels.iter().max().unwrap() as usize;
    let table = ClassTable::compute(&volume, &labels, class_count, HueTemplate::default_for(class_count)).unwrap();
    table.write(&folder.join("labels.classes.json")).unwrap();
    println!("{}", serde_json::to_string_pretty(&table).unwrap());
    let window = DisplayWindow::automatic(&volume);
    for (axis, slice) in middle_slices(volume.dims) {
        let image = slice_overlay(&volume, &labels, &table.styles, axis, slice, window, DEFAULT_OVERLAY_ALPHA).unwrap();
        write_png(&folder.join(format!("overlay_{axis}{slice}.png")), &image).unwrap();
    }
    let rgba = rgba_volume(&volume, &labels, &table.styles).unwrap();
    write_png(&folder.join("rgba_composite_z.png"), &composite_along_z(&rgba, volume.dims)).unwrap();
    // The same with the most transparent class hidden, to see what it covers.
    let mut styles = table.styles.clone();
    let faintest = (0..class_count).min_by(|&a, &b| styles[a].opacity[1].total_cmp(&styles[b].opacity[1])).unwrap();
    styles[faintest].visible = false;
    let rgba = rgba_volume(&volume, &labels, &styles).unwrap();
    write_png(
        &folder.join(format!("rgba_composite_z_without_class{}.png", faintest + 1)),
        &composite_along_z(&rgba, volume.dims),
    )
    .unwrap();
}
