//! Frame times of the ray caster: the median of `--frames` frames after a few warm-up frames,
//! each turning the camera by one degree, drawn offscreen and waited for (no readback), for
//! both render modes; and the progressive preview ([`volasso::render::progressive`]), timed as
//! the 3-D view pays for it: drawn at the size the planner picks from the frames before it and
//! read back.
//!
//! ```text
//! cargo run --release --example render_benchmark -- [VOLUME] [WIDTHxHEIGHT] [--variants]
//!     [--frames N] [--modes post,pre,preview] [--spacing X,Y,Z] [--step-voxels S] [--save PREFIX]
//!     [--upsample K] [--adapter-only]
//! ```
//!
//! Defaults: `../shared/data/engine_256x256x256_uint8.raw`, 1280x800, 10 frames, all three
//! modes, the default sample distance (half the smallest voxel spacing). `--variants` also times
//! post-classification without skipping, without shading, and at one sample per voxel; `--save`
//! writes the first frame of each line as PREFIX-NAME.png; `--upsample K` draws the volume
//! resampled K times finer per axis (nearest voxel, spacing / K: the engine at 2 is a 512^3
//! volume); `--adapter-only` prints the adapter and its device type and stops (benches/gpu.sh
//! asks it whether there is a GPU). Classes are made up: two value
//! thresholds at 1/4 and 1/2 of the value range, a faint and an opaque class (what
//! `benches/vtk_raycast.py` draws with VTK); perspective camera at the default orbit; shading,
//! jitter and empty-space skipping on.

use std::path::PathBuf;
use std::time::Instant;
use volasso::render::headless::{OFFSCREEN_FORMAT, OffscreenTarget, Scene};
use volasso::render::progressive::ProgressiveView;
use volasso::render::{Camera, RayCaster, RenderMode, RenderSettings};
use volasso::transfer::ClassStyle;
use volasso::volume::{Volume, VoxelBytes};

const WARM_UP: usize = 3;

struct Options {
    path: PathBuf,
    size: [u32; 2],
    variants: bool,
    frames: usize,
    modes: Vec<String>,
    spacing_mm: Option<[f64; 3]>,
    step_voxels: Option<f32>,
    save: Option<String>,
    upsample: usize,
    adapter_only: bool,
}

fn parse() -> Result<Options, Box<dyn std::error::Error>> {
    let mut options = Options {
        path: "../shared/data/engine_256x256x256_uint8.raw".into(),
        size: [1280, 800],
        variants: false,
        frames: 10,
        modes: vec!["post".into(), "pre".into(), "preview".into()],
        spacing_mm: None,
        step_voxels: None,
        save: None,
        upsample: 1,
        adapter_only: false,
    };
    let mut positional = 0;
    let mut arguments = std::env::args().skip(1);
    while let Some(argument) = arguments.next() {
        let mut value = || arguments.next().ok_or(format!("{argument} needs a value"));
        match argument.as_str() {
            "--variants" => options.variants = true,
            "--frames" => options.frames = value()?.parse::<usize>()?.max(1),
            "--modes" => options.modes = value()?.split(',').map(String::from).collect(),
            "--step-voxels" => options.step_voxels = Some(value()?.parse()?),
            "--save" => options.save = Some(value()?),
            "--upsample" => options.upsample = value()?.parse::<usize>()?.clamp(1, 4),
            "--adapter-only" => options.adapter_only = true,
            "--spacing" => {
                let parts: Vec<f64> = value()?.split(',').map(str::parse).collect::<Result<_, _>>()?;
                options.spacing_mm = Some(parts.try_into().map_err(|_| "--spacing takes X,Y,Z")?);
            }
            _ if positional == 0 => {
                options.path = argument.into();
                positional += 1;
            }
            _ if positional == 1 => {
                let (width, height) = argument.split_once('x').ok_or("size must be WIDTHxHEIGHT")?;
                options.size = [width.parse()?, height.parse()?];
                positional += 1;
            }
            _ => return Err(format!("unexpected argument {argument}").into()),
        }
    }
    Ok(options)
}

fn median_line(name: &str, mut milliseconds: Vec<f64>, extra: &str) {
    milliseconds.sort_by(f64::total_cmp);
    let count = milliseconds.len();
    println!(
        "{name}: median {:.1} ms over {count} frames (min {:.1}, max {:.1}){extra}",
        milliseconds[count / 2],
        milliseconds[0],
        milliseconds[count - 1]
    );
}

/// `volume` resampled `factor` times finer per axis: each voxel repeated, spacing divided.
fn upsampled(volume: Volume, factor: usize) -> Result<Volume, Box<dyn std::error::Error>> {
    if factor == 1 {
        return Ok(volume);
    }
    let [size_x, size_y, size_z] = volume.dims;
    let voxel = volume.voxel_type.size_bytes();
    let source = volume.raw_bytes();
    let row = size_x * factor * voxel;
    let mut bytes = Vec::with_capacity(source.len() * factor.pow(3));
    let mut fine_row = Vec::with_capacity(row);
    for z in 0..size_z * factor {
        for y in 0..size_y * factor {
            fine_row.clear();
            let start = volume.index(0, y / factor, z / factor) * voxel;
            for coarse in source[start..start + size_x * voxel].chunks_exact(voxel) {
                for _ in 0..factor {
                    fine_row.extend_from_slice(coarse);
                }
            }
            bytes.extend_from_slice(&fine_row);
        }
    }
    let mut fine = Volume::new(
        volume.dims.map(|side| side * factor),
        volume.spacing_mm.map(|spacing| spacing / factor as f64),
        volume.voxel_type,
        volume.byte_order,
        volume.scale,
        VoxelBytes::Owned(bytes),
        &volume.source,
    )?;
    fine.orientation = volume.orientation;
    Ok(fine)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let options = parse()?;
    let [width, height] = options.size;
    if options.adapter_only {
        let gpu = volasso::render::acquire()?;
        println!("adapter: {}, device type {:?}", gpu.adapter_name(), gpu.adapter_info.device_type);
        return Ok(());
    }
    let open = volasso::volume::OpenOptions { spacing_mm: options.spacing_mm, ..Default::default() };
    let volume = upsampled(volasso::volume::open(&options.path, &open)?, options.upsample)?;
    let range = volume.value_range();
    let thresholds = [0.25, 0.5].map(|f| (range.min + f * (range.max - range.min)) as f32);
    let mut labels = vec![0u8; volume.voxel_count()];
    let plane = volume.dims[0] * volume.dims[1];
    let mut slice = vec![0f32; plane];
    for (z, out) in labels.chunks_exact_mut(plane).enumerate() {
        volume.read_z_slice_f32(z, &mut slice);
        for (label, value) in out.iter_mut().zip(&slice) {
            *label = thresholds.iter().filter(|t| value >= *t).count() as u8;
        }
    }
    let min_spacing = volume.spacing_mm.iter().copied().fold(f64::INFINITY, f64::min);
    let gradient_max = (0.25 * (range.max - range.min) / min_spacing) as f32;
    let class = |hue: f32, opacity: [f32; 2]| ClassStyle {
        hue_degrees: [hue, hue + 30.0],
        saturation: 0.7,
        value: 0.95,
        opacity,
        gradient_max,
        emphasis: 1.0,
        visible: true,
    };
    let styles = [class(25.0, [0.05, 0.25]), class(200.0, [0.35, 0.8])];

    let gpu = volasso::render::acquire()?;
    println!("adapter: {}", gpu.adapter_name());
    println!("volume: {} {:?} {}", options.path.display(), volume.dims, volume.voxel_type.name());
    let scene = Scene { volume: &volume, labels: &labels, class_styles: &styles, rgba: None };
    let target = OffscreenTarget::new(&gpu.device, &gpu.queue, width, height, OFFSCREEN_FORMAT)?;
    let defaults = RenderSettings::default();
    let post = RenderSettings {
        mode: RenderMode::Postclassified,
        step_voxels: options.step_voxels.unwrap_or(defaults.step_voxels),
        ..defaults
    };
    let pre = RenderSettings { mode: RenderMode::Preclassified, ..post };
    let mut runs = Vec::new();
    let wanted = |mode: &str| options.modes.iter().any(|m| m == mode);
    if wanted("post") {
        runs.push(("default", post));
    }
    if wanted("pre") {
        runs.push(("default", pre));
    }
    if options.variants {
        runs.push(("no-skipping", RenderSettings { empty_space_skipping: false, ..post }));
        runs.push(("no-shading", RenderSettings { shading: false, ..post }));
        runs.push(("step-1-voxel", RenderSettings { step_voxels: 1.0, ..post }));
    }
    let camera = Camera::default();
    let orbit = |frame: usize| Camera { azimuth_degrees: camera.azimuth_degrees + frame as f32, ..camera };
    let save = |name: &str, image: &image::RgbaImage| -> Result<(), Box<dyn std::error::Error>> {
        if let Some(prefix) = &options.save {
            image.save(format!("{prefix}-{name}.png"))?;
        }
        Ok(())
    };
    let mut post_caster: Option<RayCaster> = None;
    let mut pre_caster: Option<RayCaster> = None;
    for (name, settings) in runs {
        let slot = if settings.mode == RenderMode::Postclassified { &mut post_caster } else { &mut pre_caster };
        if slot.is_none() {
            let mut ray_caster = RayCaster::new(&gpu.device, &gpu.queue, OFFSCREEN_FORMAT)?;
            scene.load_into(&mut ray_caster, settings.mode)?;
            *slot = Some(ray_caster);
        }
        let Some(ray_caster) = slot.as_mut() else { continue };
        for _ in 0..WARM_UP {
            target.draw(ray_caster, &camera, &settings)?;
        }
        let line = format!("render-{:?}-{name}-{width}x{height}", settings.mode);
        let mut milliseconds = Vec::new();
        for frame in 0..options.frames {
            let start = Instant::now();
            target.draw(ray_caster, &orbit(frame), &settings)?;
            milliseconds.push(start.elapsed().as_secs_f64() * 1e3);
            if frame == 0 {
                save(&line, &target.read_image()?)?;
            }
        }
        median_line(&line, milliseconds, "");
    }
    if wanted("preview") {
        let ray_caster = match post_caster.as_mut() {
            Some(ray_caster) => ray_caster,
            None => {
                let mut ray_caster = RayCaster::new(&gpu.device, &gpu.queue, OFFSCREEN_FORMAT)?;
                scene.load_into(&mut ray_caster, RenderMode::Postclassified)?;
                post_caster.insert(ray_caster)
            }
        };
        let mut view = ProgressiveView::new(&gpu.device, &gpu.queue);
        // The planner learns the cost of a pixel from the frames it draws, as in the 3-D view.
        for frame in 0..WARM_UP {
            view.preview(ray_caster, &orbit(frame), &post, options.size)?;
        }
        let line = format!("render-Postclassified-preview-{width}x{height}");
        let mut milliseconds = Vec::new();
        let mut sizes = Vec::new();
        for frame in 0..options.frames {
            let start = Instant::now();
            let image = view.preview(ray_caster, &orbit(frame), &post, options.size)?;
            milliseconds.push(start.elapsed().as_secs_f64() * 1e3);
            sizes.push(format!("{}x{}", image.width(), image.height()));
            if frame == 0 {
                save(&line, &image)?;
            }
        }
        let plan = view.planner().preview_plan(options.size, &post);
        let extra = format!(
            ", read back; drawn at {} (last {}), {} voxel steps",
            sizes.first().map_or("", String::as_str),
            sizes.last().map_or("", String::as_str),
            plan.settings.step_voxels
        );
        median_line(&line, milliseconds, &extra);
    }
    Ok(())
}
