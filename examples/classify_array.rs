//! Classifying a scan held as an `ndarray` array: a small volume with two structures is built
//! as an `Array3`, one scribble marks each, the pipeline classifies every voxel, and the labels
//! are written as NRRD (a label volume any viewer opens on the same grid).
//!
//! `cargo run --release --example classify_array [OUT.nrrd]`

use ndarray::{Array3, s};
use volasso::pipeline;
use volasso::segmentation::SegmentationOptions;
use volasso::volume::{ByteOrder, VoxelType, nrrd};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "classify_array.labels.nrrd".to_string());
    // 48 x 64 x 64 voxels (z, y, x) of 1 x 1 x 2 mm: a soft ball (100) and a dense rod (400)
    // in air (0), with a little deterministic texture.
    let spacing_mm = [1.0, 1.0, 2.0];
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
    // One small scribble inside each structure: 1 the ball, 2 the rod.
    let mut scribbles = Array3::<u8>::zeros(values.dim());
    scribbles.slice_mut(s![23..26, 30..34, 20..26]).fill(1);
    scribbles.slice_mut(s![23..26, 31..34, 45..48]).fill(2);

    // The background is automatic: the air joined to the volume's faces stays label 0. (On a
    // scan like this one, nearly all air with one small, very bright rod, Otsu's threshold of
    // the whole histogram splits the rod off with the ball on the air's side; the automatic
    // rule then splits the values below it again, between the air and the ball.)
    let options = SegmentationOptions::default();
    let result = pipeline::classify_array(values.view(), spacing_mm, scribbles.view(), &options)?;
    let mut counts = [0usize; 3];
    for &label in &result.labels {
        counts[label as usize] += 1;
    }
    println!("background {} voxels, ball (class 1) {}, rod (class 2) {}", counts[0], counts[1], counts[2]);

    let (nz, ny, nx) = result.labels.dim();
    let bytes: Vec<u8> = result.labels.iter().copied().collect();
    nrrd::write(
        out.as_ref(),
        [nx, ny, nz],
        spacing_mm,
        VoxelType::U8,
        ByteOrder::Little,
        &bytes,
        "classify_array example",
    )?;
    println!("wrote {out}");
    Ok(())
}
