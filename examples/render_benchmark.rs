//! Frame time of the ray caster: the median of `FRAMES` frames after `WARM_UP` frames, each
//! drawn offscreen and waited for (no readback), for both render modes.
//!
//! `cargo run --release --example render_benchmark -- [VOLUME] [WIDTHxHEIGHT] [--variants]`
//! (defaults: `../shared/data/engine_256x256x256_uint8.raw`, 1280x800; `--variants` also times
//! post-classification without skipping, without shading, and at one sample per voxel).
//! Classes are made up:
//! two value thresholds at 1/4 and 1/2 of the value range, a faint and an opaque class,
//! perspective camera at the default orbit, shading, jitter and empty-space skipping on.

use std::path::PathBuf;
use std::time::Instant;
use volasso::render::headless::{OFFSCREEN_FORMAT, OffscreenTarget, Scene};
use volasso::render::{Camera, RayCaster, RenderMode, RenderSettings};
use volasso::transfer::ClassStyle;

const WARM_UP: usize = 3;
const FRAMES: usize = 10;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut arguments = std::env::args().skip(1);
    let path = PathBuf::from(arguments.next().unwrap_or_else(|| "../shared/data/engine_256x256x256_uint8.raw".into()));
    let size = arguments.next().unwrap_or_else(|| "1280x800".into());
    let variants = arguments.next().is_some_and(|a| a == "--variants");
    let (width, height) = size.split_once('x').ok_or("size must be WIDTHxHEIGHT")?;
    let (width, height): (u32, u32) = (width.parse()?, height.parse()?);

    let volume = volasso::volume::open(&path, &Default::default())?;
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
    let gradient_max = (0.25 * (range.max - range.min)) as f32;
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
    println!("volume: {} {:?} {}", path.display(), volume.dims, volume.voxel_type.name());
    let scene = Scene { volume: &volume, labels: &labels, class_styles: &styles, rgba: None };
    let target = OffscreenTarget::new(&gpu.device, &gpu.queue, width, height, OFFSCREEN_FORMAT)?;
    let post = RenderSettings { mode: RenderMode::Postclassified, ..RenderSettings::default() };
    let pre = RenderSettings { mode: RenderMode::Preclassified, ..post };
    let mut runs = vec![("default", post), ("default", pre)];
    if variants {
        runs.push(("no-skipping", RenderSettings { empty_space_skipping: false, ..post }));
        runs.push(("no-shading", RenderSettings { shading: false, ..post }));
        runs.push(("step-1-voxel", RenderSettings { step_voxels: 1.0, ..post }));
    }
    let mut loaded: Option<(RenderMode, RayCaster)> = None;
    for (name, settings) in runs {
        let mut ray_caster = match loaded.take() {
            Some((mode, ray_caster)) if mode == settings.mode => ray_caster,
            _ => {
                let mut ray_caster = RayCaster::new(&gpu.device, &gpu.queue, OFFSCREEN_FORMAT)?;
                scene.load_into(&mut ray_caster, settings.mode)?;
                ray_caster
            }
        };
        let camera = Camera::default();
        for _ in 0..WARM_UP {
            target.draw(&mut ray_caster, &camera, &settings)?;
        }
        let mut milliseconds: Vec<f64> = (0..FRAMES)
            .map(|frame| {
                let orbit = Camera { azimuth_degrees: camera.azimuth_degrees + frame as f32, ..camera };
                let start = Instant::now();
                target.draw(&mut ray_caster, &orbit, &settings).map(|()| start.elapsed().as_secs_f64() * 1e3)
            })
            .collect::<Result<_, _>>()?;
        milliseconds.sort_by(f64::total_cmp);
        println!(
            "render-{:?}-{name}-{width}x{height}: median {:.1} ms over {FRAMES} frames (min {:.1}, max {:.1})",
            settings.mode,
            milliseconds[FRAMES / 2],
            milliseconds[0],
            milliseconds[FRAMES - 1]
        );
        loaded = Some((settings.mode, ray_caster));
    }
    Ok(())
}
