//! Fixtures for the render tests: the shared GPU, phantoms with known geometry, made-up class
//! tables, and image measurements.
//!
//! Set `VOLASSO_RENDER_LOOK=/some/folder` to have tests write the images they check there.

use super::headless::{OFFSCREEN_FORMAT, OffscreenTarget};
use super::volume_texture::VolumeGeometry;
use super::{Camera, Gpu, RayCaster, RenderMode, RenderSettings};
use crate::transfer::ClassStyle;
use crate::volume::{ByteOrder, ValueScale, Volume, VoxelBytes, VoxelType};
use std::path::Path;
use std::sync::OnceLock;

/// One device for every test (tests run in parallel threads; wgpu devices are shareable).
pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    GPU.get_or_init(|| match super::gpu::acquire() {
        Ok(gpu) => gpu,
        Err(error) => panic!("render tests need a GPU adapter: {error}"),
    })
}

/// A scalar volume whose value is a function of the label, and the labels.
pub struct Phantom {
    pub volume: Volume,
    pub labels: Vec<u8>,
}

impl Phantom {
    /// Labels from `label_at(voxel centre in world mm)`, world being centred on the box;
    /// values `60 * label` stored as `voxel_type` (`U8` or `I16`, the latter offset by -500
    /// to exercise the 16-bit path and negative values).
    pub fn new(
        dims: [usize; 3],
        spacing_mm: [f64; 3],
        voxel_type: VoxelType,
        label_at: impl Fn([f32; 3]) -> u8,
    ) -> Phantom {
        let mut labels = Vec::with_capacity(dims.iter().product());
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let voxel = [x, y, z];
                    let world: [f32; 3] = std::array::from_fn(|a| {
                        ((voxel[a] as f64 + 0.5 - dims[a] as f64 / 2.0) * spacing_mm[a]) as f32
                    });
                    labels.push(label_at(world));
                }
            }
        }
        let bytes: Vec<u8> = match voxel_type {
            VoxelType::U8 => labels.iter().map(|l| l * 60).collect(),
            VoxelType::I16 => labels.iter().flat_map(|&l| (l as i16 * 60 - 500).to_le_bytes()).collect(),
            other => panic!("phantoms are U8 or I16, not {other:?}"),
        };
        let volume = Volume::new(
            dims,
            spacing_mm,
            voxel_type,
            ByteOrder::Little,
            ValueScale::IDENTITY,
            VoxelBytes::Owned(bytes),
            Path::new("phantom"),
        )
        .unwrap();
        Phantom { volume, labels }
    }

    /// World position (mm) of a point given in voxel index coordinates (voxel centres at
    /// integers).
    pub fn world_of_voxel(&self, voxel: [f32; 3]) -> [f32; 3] {
        std::array::from_fn(|a| {
            ((voxel[a] as f64 + 0.5 - self.volume.dims[a] as f64 / 2.0) * self.volume.spacing_mm[a]) as f32
        })
    }

    /// A ray caster drawing offscreen with this phantom loaded for `mode`.
    pub fn ray_caster(&self, styles: &[ClassStyle], mode: RenderMode) -> RayCaster {
        let gpu = gpu();
        let mut ray_caster = RayCaster::new(&gpu.device, &gpu.queue, OFFSCREEN_FORMAT).unwrap();
        ray_caster.set_class_table(styles).unwrap();
        match mode {
            RenderMode::Postclassified => {
                ray_caster.set_volume(&self.volume).unwrap();
                ray_caster.set_labels(&self.labels).unwrap();
            }
            RenderMode::Preclassified => {
                let rgba = super::preclassify::preclassified_rgba(&self.volume, &self.labels, styles).unwrap();
                ray_caster.set_rgba(VolumeGeometry::of(&self.volume), &rgba).unwrap();
            }
        }
        ray_caster
    }
}

/// A class of one hue (range `hue .. hue + 8` over the gradient factor), saturation and value
/// 0.9, constant opacity.
pub fn style(hue_degrees: f32, opacity: f32) -> ClassStyle {
    ClassStyle {
        hue_degrees: [hue_degrees, hue_degrees + 8.0],
        saturation: 0.9,
        value: 0.9,
        opacity: [opacity, opacity],
        gradient_max: 30.0,
        emphasis: 1.0,
        visible: true,
    }
}

/// Unshaded, unjittered-off defaults for measuring: transparent background, jitter on.
pub fn flat(mode: RenderMode) -> RenderSettings {
    RenderSettings { mode, shading: false, background: [0.0; 4], ..RenderSettings::default() }
}

/// Draws one `size` frame with `ray_caster`.
pub fn capture(
    ray_caster: &mut RayCaster,
    camera: &Camera,
    settings: &RenderSettings,
    size: [u32; 2],
) -> image::RgbaImage {
    let gpu = gpu();
    let target = OffscreenTarget::new(&gpu.device, &gpu.queue, size[0], size[1], OFFSCREEN_FORMAT).unwrap();
    target.capture(ray_caster, camera, settings).unwrap()
}

/// Writes `image` to `$VOLASSO_RENDER_LOOK/name.png` when that variable is set.
pub fn look(name: &str, image: &image::RgbaImage) {
    if let Some(folder) = std::env::var_os("VOLASSO_RENDER_LOOK") {
        let folder = Path::new(&folder);
        std::fs::create_dir_all(folder).unwrap();
        super::headless::write_png(&folder.join(format!("{name}.png")), image).unwrap();
    }
}

/// The radius of a disc with the area of the pixels at least half opaque.
pub fn opaque_disc_radius(image: &image::RgbaImage) -> f32 {
    let count = image.pixels().filter(|p| p[3] >= 128).count();
    (count as f32 / std::f32::consts::PI).sqrt()
}

/// The centroid (pixel-centre coordinates) of the pixels at least half opaque.
pub fn opaque_centroid(image: &image::RgbaImage) -> [f32; 2] {
    let (mut sum, mut count) = ([0.0f64; 2], 0.0f64);
    for (x, y, p) in image.enumerate_pixels() {
        if p[3] >= 128 {
            sum[0] += x as f64 + 0.5;
            sum[1] += y as f64 + 0.5;
            count += 1.0;
        }
    }
    [(sum[0] / count) as f32, (sum[1] / count) as f32]
}

/// The pixel under a position given in pixel-centre coordinates.
pub fn pixel_at(image: &image::RgbaImage, position: [f32; 2]) -> [f32; 4] {
    let p = image.get_pixel(position[0].floor() as u32, position[1].floor() as u32);
    p.0.map(|c| c as f32 / 255.0)
}

/// Hue (degrees), saturation and value of an RGB colour in [0, 1].
pub fn hsv(rgb: [f32; 3]) -> [f32; 3] {
    let max = rgb.iter().copied().fold(0.0, f32::max);
    let min = rgb.iter().copied().fold(1.0, f32::min);
    let chroma = max - min;
    let hue = if chroma <= 0.0 {
        0.0
    } else if max == rgb[0] {
        60.0 * ((rgb[1] - rgb[2]) / chroma).rem_euclid(6.0)
    } else if max == rgb[1] {
        60.0 * ((rgb[2] - rgb[0]) / chroma + 2.0)
    } else {
        60.0 * ((rgb[0] - rgb[1]) / chroma + 4.0)
    };
    [hue, if max > 0.0 { chroma / max } else { 0.0 }, max]
}

/// The angular distance between two hues in degrees.
pub fn hue_distance(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// Per pixel, the largest difference of any channel, in 1/255 steps.
pub fn channel_differences(a: &image::RgbaImage, b: &image::RgbaImage) -> Vec<u8> {
    a.pixels().zip(b.pixels()).map(|(p, q)| (0..4).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0)).collect()
}
