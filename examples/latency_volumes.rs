//! The two scans the latency figures are measured on (benches/RESULTS.md), written as NRRD with
//! a strokes file each: a 16-bit T1-like head MRI of 181 x 217 x 181 voxels (BrainWeb's grid) and
//! an 8-bit windowed chest CT of 256 x 256 x 133 voxels, each with loops inside three of its
//! classes on the slices the kiosk shows first (`phantom::lassos_inside`).
//!
//! `cargo run --release --example latency_volumes -- DIR`, then for example
//! `volasso classify DIR/head-mri.nrrd --strokes DIR/head-mri.strokes.json --out L.nrrd --repeat 5`.

use std::path::PathBuf;
use volasso::phantom::{self, Phantom};
use volasso::volume::nrrd;

fn write(
    phantom: &Phantom,
    classes: &[u8],
    folder: &std::path::Path,
    name: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    nrrd::write_volume(&folder.join(format!("{name}.nrrd")), &phantom.volume, name)?;
    phantom::lassos_inside(phantom, classes, 2, 2.5).write(&folder.join(format!("{name}.strokes.json")))?;
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let folder = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "latency-volumes".to_string()));
    std::fs::create_dir_all(&folder)?;
    // Skull, CSF and white matter of the head (its folded grey matter leaves no room for an
    // octagon inside it); soft tissue, lung and bone of the chest.
    write(&phantom::procedural::brain_mri([181, 217, 181], 1)?, &[2, 3, 5], &folder, "head-mri")?;
    write(&phantom::bodies::chest_ct_windowed([256, 256, 133], 1)?, &[2, 3, 4], &folder, "chest-ct")?;
    println!("{}", folder.display());
    Ok(())
}
