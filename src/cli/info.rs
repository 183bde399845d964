//! `volasso info VOLUME`: what a volume is, as the readers see it.

use super::args::InfoArgs;
use super::{CliError, memory};
use crate::volume::Volume;
use serde::Serialize;

/// The facts `info` reports; also its `--json` output.
#[derive(Debug, Serialize)]
pub struct VolumeInfo {
    pub source: String,
    pub dims: [usize; 3],
    #[serde(rename = "type")]
    pub voxel_type: &'static str,
    pub spacing_mm: [f64; 3],
    pub value_min: f64,
    pub value_max: f64,
    pub non_finite_voxels: u64,
    pub memory_mapped: bool,
    /// The slice the work screen opens on, along x, y and z: the highest foreground entropy
    /// (paper §3.1, eq. 1) inside the body ([`crate::slices::foreground_slice_entropies`]).
    pub top_slices: [usize; 3],
    /// The patient direction each voxel axis x, y, z increases toward, in DICOM's letters
    /// (nearest for oblique axes), or `null` when the file does not say (`interfaces.md`).
    pub anatomical_axes: Option<[&'static str; 3]>,
    pub resident_memory: Option<memory::ResidentMemory>,
    /// What the reader tolerated or changed (a DICOM series resampled, opened across a gap).
    pub warnings: Vec<String>,
}

impl VolumeInfo {
    pub fn of(volume: &Volume) -> VolumeInfo {
        let range = volume.value_range();
        VolumeInfo {
            source: volume.source.display().to_string(),
            dims: volume.dims,
            voxel_type: volume.voxel_type.name(),
            spacing_mm: volume.spacing_mm,
            value_min: range.min,
            value_max: range.max,
            non_finite_voxels: range.non_finite_voxels,
            memory_mapped: volume.is_memory_mapped(),
            top_slices: crate::slices::foreground_slice_entropies(volume).top_slices(),
            anatomical_axes: volume.orientation.map(|orientation| orientation.anatomical_letters()),
            resident_memory: memory::resident_memory(),
            warnings: volume.warnings.clone(),
        }
    }
}

pub fn run(args: &InfoArgs) -> Result<(), CliError> {
    let volume = super::open_volume(&args.volume, &args.open)?;
    let info = VolumeInfo::of(&volume);
    if args.json {
        println!("{}", serde_json::to_string(&info).unwrap_or_default());
        return Ok(());
    }
    let mib = |bytes: u64| bytes as f64 / (1024.0 * 1024.0);
    println!("volume:      {}", info.source);
    println!("dimensions:  {} x {} x {}", info.dims[0], info.dims[1], info.dims[2]);
    println!(
        "type:        {}{}",
        info.voxel_type,
        if volume.scale.is_identity() {
            String::new()
        } else {
            format!(" (scaled: x {} + {})", volume.scale.slope, volume.scale.intercept)
        }
    );
    println!("spacing:     {} x {} x {} mm", info.spacing_mm[0], info.spacing_mm[1], info.spacing_mm[2]);
    println!("value range: {} .. {}", info.value_min, info.value_max);
    if info.non_finite_voxels > 0 {
        println!("non-finite:  {} voxels (NaN or infinite)", info.non_finite_voxels);
    }
    match info.anatomical_axes {
        Some([x, y, z]) => println!("orientation: x toward {x}, y toward {y}, z toward {z} (patient, DICOM letters)"),
        None => println!("orientation: unknown (the file does not say)"),
    }
    println!(
        "top slices:  x {}, y {}, z {} (highest entropy inside the body)",
        info.top_slices[0], info.top_slices[1], info.top_slices[2]
    );
    println!("storage:     {}", if info.memory_mapped { "memory-mapped" } else { "in memory" });
    for warning in &info.warnings {
        println!("warning:     {warning}");
    }
    if let Some(memory) = info.resident_memory {
        println!(
            "resident:    {:.1} MiB anonymous, {:.1} MiB of mapped files, peak {:.1} MiB",
            mib(memory.anonymous_bytes),
            mib(memory.file_backed_bytes),
            mib(memory.peak_bytes)
        );
    }
    Ok(())
}
