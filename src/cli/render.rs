//! `volasso render VOLUME --strokes S.json --out IMAGE.png`: classify with the defaults of
//! `classify` (an MR scan's shading divided out as there: `--modality`, `--keep-shading`), colour with the default hue template, and ray-cast one frame headless (wgpu;
//! Mesa's lavapipe where there is no GPU). The PNG is written whole or not at all, and the
//! temporary files killed runs left beside it are removed first.

use super::CliError;
use super::args::{RenderArgs, RenderModeChoice};
use crate::pipeline::{self, RunControl};
use crate::render::headless::{Scene, render_png};
use crate::render::{Camera, RenderMode, RenderSettings, gpu};
use crate::segmentation::SegmentationOptions;
use crate::strokes::StrokesFile;

pub fn run(args: &RenderArgs) -> Result<(), CliError> {
    let output = [("image (--out)", args.out.as_path())];
    super::outputs::check(&[("volume", &args.volume), ("strokes file (--strokes)", &args.strokes)], &output)?;
    for removed in crate::atomic_file::remove_stale_temporaries(&args.out) {
        log::info!("removed {}, left by a run that was stopped", removed.display());
    }
    let volume = super::open_volume(&args.volume, &args.open)?;
    super::outputs::check_mapped("volume's voxel data", &output)?;
    let strokes = StrokesFile::read_for_volume(&args.strokes, volume.dims)?;
    let modality = args.scan.modality(&args.volume, &args.open);
    let options = SegmentationOptions { correct_shading: args.scan.corrects_shading(modality), ..Default::default() };
    let classified = pipeline::classify_strokes(&volume, &strokes, &options, None, RunControl::batch())
        .map_err(|error| super::pipeline_error(error, &args.strokes))?;
    let (labels, table) = (classified.labels, classified.table);
    let class_count = strokes.classes.len();

    let gpu = gpu::acquire()?;
    log::info!("rendering on {} ({:?})", gpu.adapter_info.name, gpu.adapter_info.backend);
    let camera = Camera {
        azimuth_degrees: args.azimuth,
        elevation_degrees: args.elevation,
        zoom: args.zoom,
        ..Camera::default()
    };
    let settings = RenderSettings {
        mode: match args.mode {
            RenderModeChoice::Pre => RenderMode::Preclassified,
            RenderModeChoice::Post => RenderMode::Postclassified,
        },
        ..RenderSettings::default()
    };
    let scene = Scene { volume: &volume, labels: &labels.labels, class_styles: &table.styles, rgba: None };
    render_png(&args.out, &gpu.device, &gpu.queue, &scene, &camera, &settings, args.size)?;
    println!("wrote {} ({}x{}, {} classes)", args.out.display(), args.size[0], args.size[1], class_count);
    Ok(())
}
