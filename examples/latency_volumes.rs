//! The two scans the latency figures are measured on (benches/RESULTS.md): a 16-bit T1-like head
//! MRI of 181 x 217 x 181 voxels (BrainWeb's grid) and an 8-bit windowed chest CT of
//! 256 x 256 x 133 voxels, each with loops inside three of its classes on the slices the kiosk
//! shows first (`phantom::lassos_inside`).
//!
//! `cargo run --release --example latency_volumes -- DIR` writes them as NRRD with a strokes
//! file each, for example for
//! `volasso classify DIR/head-mri.nrrd --strokes DIR/head-mri.strokes.json --out L.nrrd --repeat 5`.
//! `cargo run --release --example latency_volumes -- DIR --time 5` also classifies each five
//! times through the kiosk's call (`pipeline::classify_strokes` with a first-look receiver, the
//! body outline found beforehand as the kiosk finds it when the scan opens; the MRI's shading
//! divided out, as for an MR series) and prints the median time to the coarse first look and to
//! the exact labels.

use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::AtomicBool;
use std::time::Instant;
use volasso::phantom::{self, Phantom};
use volasso::pipeline::{self, RunControl};
use volasso::segmentation::{LabelVolume, SegmentationOptions};
use volasso::volume::nrrd;

fn write(
    phantom: &Phantom,
    classes: &[u8],
    folder: &std::path::Path,
    name: &str,
    mr: bool,
    repeats: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    nrrd::write_volume(&folder.join(format!("{name}.nrrd")), &phantom.volume, name)?;
    let strokes = phantom::lassos_inside(phantom, classes, 2, 2.5);
    strokes.write(&folder.join(format!("{name}.strokes.json")))?;
    if repeats == 0 {
        return Ok(());
    }
    let volume = &phantom.volume;
    let _ = volume.body();
    // An MR series has its shading divided out, as the kiosk does.
    let options = SegmentationOptions { correct_shading: mr, ..SegmentationOptions::default() };
    let (mut first_looks, mut exact) = (Vec::new(), Vec::new());
    for _ in 0..repeats {
        let started = Instant::now();
        let first_look = Mutex::new(None);
        let preview = |_: &LabelVolume| {
            if let Ok(mut seen) = first_look.lock() {
                *seen = Some(started.elapsed().as_secs_f64());
            }
        };
        let cancel = AtomicBool::new(false);
        let control = RunControl { progress: &|_| {}, cancel: &cancel, preview: Some(&preview) };
        pipeline::classify_strokes(volume, &strokes, &options, None, control)?;
        exact.push(started.elapsed().as_secs_f64());
        first_looks.push(first_look.lock().ok().and_then(|seen| *seen).unwrap_or(f64::NAN));
    }
    println!(
        "{name} {:?}: first look {:.3} s, exact labels {:.3} s (medians of {repeats})",
        volume.dims,
        median(&mut first_looks),
        median(&mut exact)
    );
    Ok(())
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arguments: Vec<String> = std::env::args().skip(1).collect();
    let folder = PathBuf::from(arguments.first().cloned().unwrap_or_else(|| "latency-volumes".to_string()));
    let repeats = match arguments.iter().position(|argument| argument == "--time") {
        Some(at) => arguments.get(at + 1).and_then(|n| n.parse().ok()).ok_or("--time takes a count")?,
        None => 0,
    };
    std::fs::create_dir_all(&folder)?;
    // Skull, CSF and white matter of the head (its folded grey matter leaves no room for an
    // octagon inside it); soft tissue, lung and bone of the chest.
    write(&phantom::procedural::brain_mri([181, 217, 181], 1)?, &[2, 3, 5], &folder, "head-mri", true, repeats)?;
    write(&phantom::bodies::chest_ct_windowed([256, 256, 133], 1)?, &[2, 3, 4], &folder, "chest-ct", false, repeats)?;
    println!("{}", folder.display());
    Ok(())
}
