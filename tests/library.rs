//! The library's array entry (`pipeline::classify_array`) gives the same labels as
//! `volasso classify` on the same volume and strokes: one pipeline behind both.

use crate::support;
use ndarray::Array3;
use volasso::pipeline;
use volasso::segmentation::SegmentationOptions;
use volasso::strokes::{StrokesFile, TrainingSet};
use volasso::volume::{ByteOrder, VoxelType, nrrd};

/// A 40 x 48 x 56 (z, y, x) scan: a dim ball and a bright rod in noisy air, the noise from a
/// fixed hash so the file and the array hold the same values.
fn scan() -> Array3<f32> {
    Array3::from_shape_fn((40, 48, 56), |(z, y, x)| {
        let noise = (volasso::rng::hash64(7, (x + 56 * (y + 48 * z)) as u64) % 1000) as f32 / 100.0 - 5.0;
        let (zf, yf, xf) = (z as f32, y as f32, x as f32);
        if (yf - 24.0).powi(2) + (xf - 40.0).powi(2) < 30.0 && (8.0..32.0).contains(&zf) {
            400.0 + noise
        } else if ((zf - 20.0).powi(2) + (yf - 24.0).powi(2) + (xf - 18.0).powi(2)).sqrt() < 12.0 {
            120.0 + noise
        } else {
            10.0 + noise
        }
    })
}

#[test]
fn the_array_entry_labels_as_volasso_classify_does() {
    let work = tempfile::tempdir().unwrap();
    let values = scan();
    let (nz, ny, nx) = values.dim();
    let spacing = [0.8, 0.8, 1.5];
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let volume_path = work.path().join("scan.nrrd");
    nrrd::write(&volume_path, [nx, ny, nz], spacing, VoxelType::F32, ByteOrder::Little, &bytes, "test scan").unwrap();

    // A small loop inside each structure on the axial slice z = 20 (voxel coordinates x, y).
    let strokes_text = r#"{"format":"volasso-strokes/1","classes":[
        {"name":"ball","strokes":[{"axis":"z","slice":20,"points":[[14,20],[22,20],[22,28],[14,28]]}]},
        {"name":"rod","strokes":[{"axis":"z","slice":20,"points":[[38,22],[42,22],[42,26],[38,26]]}]}]}"#;
    let strokes_path = work.path().join("scan.strokes.json");
    std::fs::write(&strokes_path, strokes_text).unwrap();
    let labels_path = work.path().join("labels.nrrd");
    let output = support::volasso(
        &[
            "classify",
            volume_path.to_str().unwrap(),
            "--strokes",
            strokes_path.to_str().unwrap(),
            "--out",
            labels_path.to_str().unwrap(),
        ],
        work.path(),
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let cli_labels = nrrd::read(&labels_path).unwrap().volume;

    // The same training voxels as scribbles: voxel index i (x fastest) is element i of the
    // array in [z, y, x] order.
    let strokes = StrokesFile::parse(strokes_text).unwrap();
    let training = TrainingSet::from_strokes(&strokes, [nx, ny, nz]).unwrap();
    assert!(training.classes.iter().all(|c| c.voxels.len() < 256), "no class is capped");
    let mut scribbles = Array3::<u8>::zeros(values.dim());
    let flat = scribbles.as_slice_mut().unwrap();
    for (k, class) in training.classes.iter().enumerate() {
        for &voxel in &class.voxels {
            flat[voxel] = k as u8 + 1;
        }
    }
    let result =
        pipeline::classify_array(values.view(), spacing, scribbles.view(), &SegmentationOptions::default()).unwrap();

    let cli: Vec<u8> = cli_labels.raw_bytes().to_vec();
    let array: Vec<u8> = result.labels.iter().copied().collect();
    assert_eq!(cli.len(), array.len());
    let differing = cli.iter().zip(&array).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "labels that differ between volasso classify and the array entry");
    let ball = array.iter().filter(|&&l| l == 1).count();
    let rod = array.iter().filter(|&&l| l == 2).count();
    assert!(ball > 5000 && rod > 1500, "both structures are found: ball {ball}, rod {rod}");
}

/// The scan of `examples/classify_array.rs`: nearly all air with a soft ball and a small, very
/// bright rod, where Otsu's threshold of the whole histogram splits the rod off with the ball on
/// the air's side. The automatic background still leaves the air unlabelled.
#[test]
fn the_examples_scan_keeps_its_air_background_with_the_automatic_level() {
    let values = Array3::from_shape_fn((48, 64, 64), |(z, y, x)| {
        let (zf, yf, xf) = (z as f32 * 2.0, y as f32, x as f32);
        let ball = ((zf - 48.0).powi(2) + (yf - 32.0).powi(2) + (xf - 24.0).powi(2)).sqrt() < 14.0;
        let rod = (yf - 32.0).powi(2) + (xf - 46.0).powi(2) < 25.0 && (16.0..80.0).contains(&zf);
        let texture = ((x * 7 + y * 13 + z * 17) % 11) as f32 - 5.0;
        if rod {
            400.0 + texture
        } else if ball {
            100.0 + texture
        } else {
            texture.abs()
        }
    });
    let mut scribbles = Array3::<u8>::zeros(values.dim());
    scribbles.slice_mut(ndarray::s![23..26, 30..34, 20..26]).fill(1);
    scribbles.slice_mut(ndarray::s![23..26, 31..34, 45..48]).fill(2);
    let result =
        pipeline::classify_array(values.view(), [1.0, 1.0, 2.0], scribbles.view(), &SegmentationOptions::default())
            .unwrap();
    let (mut air, mut air_labelled, mut ball, mut rod) = (0, 0, 0, 0);
    for (&value, &label) in values.iter().zip(result.labels.iter()) {
        if value <= 5.0 {
            air += 1;
            air_labelled += usize::from(label != 0);
        } else if value < 200.0 {
            ball += usize::from(label == 1);
        } else {
            rod += usize::from(label == 2);
        }
    }
    assert!(air_labelled * 100 < air, "{air_labelled} of {air} air voxels have a class");
    assert!(ball > 4000 && rod > 1500, "both structures are found: ball {ball}, rod {rod}");
}
