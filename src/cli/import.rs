//! `volasso import SOURCE --out VOLUME.nrrd`: any readable volume (a DICOM series, a gzip NRRD,
//! a NIfTI) into a raw NRRD that later opens memory-mapped.

use super::CliError;
use super::args::ImportArgs;
use crate::volume::nrrd;

pub fn run(args: &ImportArgs) -> Result<(), CliError> {
    let output = [("imported volume (--out)", args.out.as_path())];
    super::outputs::check(&[("source volume", &args.source)], &output)?;
    let volume = super::open_volume(&args.source, &args.open)?;
    super::outputs::check_mapped("source volume's voxel data", &output)?;
    nrrd::write_volume(&args.out, &volume, &format!("imported by volasso from {}", volume.source.display()))?;
    let range = volume.value_range();
    println!(
        "wrote {}: {} x {} x {} {}, spacing {} x {} x {} mm, values {} .. {}",
        args.out.display(),
        volume.dims[0],
        volume.dims[1],
        volume.dims[2],
        if volume.scale.is_identity() { volume.voxel_type.name() } else { "float32" },
        volume.spacing_mm[0],
        volume.spacing_mm[1],
        volume.spacing_mm[2],
        range.min,
        range.max
    );
    Ok(())
}
