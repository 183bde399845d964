//! Headless rendering: a [`RayCaster`] drawing into an offscreen texture that is read back as
//! an image, for `volasso render`, tests and benchmarks.
//!
//! Entry points: [`render_to_image`] and [`render_png`] (everything from a [`Scene`]), or
//! [`OffscreenTarget`] to draw many frames with one loaded ray caster.
//!
//! Never: opens a window or a surface; writes a PNG except whole (temporary file + rename).

use super::preclassify::preclassified_rgba;
use super::volume_texture::VolumeGeometry;
use super::{Camera, PixelRegion, RayCaster, RenderError, RenderMode, RenderSettings};
use crate::transfer::ClassStyle;
use crate::volume::Volume;
use std::path::Path;

/// The format of offscreen targets: 8-bit RGBA holding the shader's display values as they are.
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// What to draw: a volume, its labels and class table, and optionally the paper's
/// pre-classified RGBA volume.
#[derive(Clone, Copy, Debug)]
pub struct Scene<'a> {
    /// The scalar volume.
    pub volume: &'a Volume,
    /// One label per voxel (0 background, k = `class_styles[k - 1]`).
    pub labels: &'a [u8],
    /// Colour, opacity and visibility of each class, in class order.
    pub class_styles: &'a [ClassStyle],
    /// 4 bytes per voxel, straight alpha; when `None`, pre-classified rendering computes it
    /// from the labels and styles ([`preclassified_rgba`]).
    pub rgba: Option<&'a [u8]>,
}

impl Scene<'_> {
    /// Uploads what `mode` needs into `ray_caster`.
    pub fn load_into(&self, ray_caster: &mut RayCaster, mode: RenderMode) -> Result<(), RenderError> {
        ray_caster.set_class_table(self.class_styles)?;
        match mode {
            RenderMode::Postclassified => {
                ray_caster.set_volume(self.volume)?;
                ray_caster.set_labels(self.labels)
            }
            RenderMode::Preclassified => {
                let geometry = VolumeGeometry::of(self.volume);
                match self.rgba {
                    Some(rgba) => ray_caster.set_rgba(geometry, rgba),
                    None => {
                        let rgba = preclassified_rgba(self.volume, self.labels, self.class_styles)?;
                        ray_caster.set_rgba(geometry, &rgba)
                    }
                }
            }
        }
    }
}

/// An offscreen colour texture and the buffer its pixels are read back through.
pub struct OffscreenTarget {
    device: wgpu::Device,
    queue: wgpu::Queue,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    readback_buffer: wgpu::Buffer,
    size: [u32; 2],
    /// Rows in the readback buffer are padded to `COPY_BYTES_PER_ROW_ALIGNMENT`.
    padded_bytes_per_row: u32,
}

impl OffscreenTarget {
    /// A `width x height` target of `format` (an 8-bit RGBA format).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        width: u32,
        height: u32,
        format: wgpu::TextureFormat,
    ) -> Result<OffscreenTarget, RenderError> {
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::BadSetting {
                name: "image size",
                value: format!("{width}x{height}"),
                expected: "1 to the GPU's max_texture_dimension_2d pixels per side",
            });
        }
        if !matches!(format, wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb) {
            return Err(RenderError::WrongTargetFormat { found: format });
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen render target"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let padded_bytes_per_row = (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let readback_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("offscreen readback"),
            size: padded_bytes_per_row as u64 * height as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Ok(OffscreenTarget {
            device: device.clone(),
            queue: queue.clone(),
            texture,
            view,
            readback_buffer,
            size: [width, height],
            padded_bytes_per_row,
        })
    }

    /// Draws one frame and waits for the GPU to finish it (what a frame time measures).
    pub fn draw(
        &self,
        ray_caster: &mut RayCaster,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<(), RenderError> {
        self.draw_region(ray_caster, camera, settings, None)
    }

    /// The width and height of the target in pixels.
    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// Draws `region` of a frame (`None`: all of it) and waits for the GPU to finish it.
    pub fn draw_region(
        &self,
        ray_caster: &mut RayCaster,
        camera: &Camera,
        settings: &RenderSettings,
        region: Option<PixelRegion>,
    ) -> Result<(), RenderError> {
        if ray_caster.target_format() != self.texture.format() {
            return Err(RenderError::WrongTargetFormat { found: ray_caster.target_format() });
        }
        ray_caster.resize(self.size[0], self.size[1]);
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("offscreen frame") });
        ray_caster.render_region(&mut encoder, &self.view, camera, settings, region)?;
        let submission = self.queue.submit([encoder.finish()]);
        self.wait(submission)
    }

    /// Copies the last frame back to the CPU.
    pub fn read_image(&self) -> Result<image::RgbaImage, RenderError> {
        let [width, height] = self.size;
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("offscreen readback") });
        encoder.copy_texture_to_buffer(
            self.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback_buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_bytes_per_row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        let submission = self.queue.submit([encoder.finish()]);
        let (sender, receiver) = std::sync::mpsc::channel();
        self.readback_buffer.map_async(wgpu::MapMode::Read, .., move |result| {
            let _ = sender.send(result);
        });
        self.wait(submission)?;
        let read_back = |problem: String| RenderError::ReadBack { problem };
        receiver
            .recv()
            .map_err(|_| read_back("the map callback never ran".into()))?
            .map_err(|error| read_back(error.to_string()))?;
        let mut pixels = Vec::with_capacity(4 * width as usize * height as usize);
        {
            let mapped = self.readback_buffer.get_mapped_range(..).map_err(|error| read_back(error.to_string()))?;
            for row in mapped.chunks_exact(self.padded_bytes_per_row as usize) {
                pixels.extend_from_slice(&row[..4 * width as usize]);
            }
        }
        self.readback_buffer.unmap();
        image::RgbaImage::from_raw(width, height, pixels).ok_or(read_back("the image has the wrong size".into()))
    }

    /// Draws one frame and reads it back.
    pub fn capture(
        &self,
        ray_caster: &mut RayCaster,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<image::RgbaImage, RenderError> {
        self.draw(ray_caster, camera, settings)?;
        self.read_image()
    }

    fn wait(&self, submission: wgpu::SubmissionIndex) -> Result<(), RenderError> {
        self.device
            .poll(wgpu::PollType::Wait { submission_index: Some(submission), timeout: None })
            .map(|_| ())
            .map_err(|error| RenderError::ReadBack { problem: error.to_string() })
    }
}

/// Renders `scene` once into a `size = [width, height]` image.
pub fn render_to_image(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    size: [u32; 2],
) -> Result<image::RgbaImage, RenderError> {
    settings.validate()?;
    let target = OffscreenTarget::new(device, queue, size[0], size[1], OFFSCREEN_FORMAT)?;
    let mut ray_caster = RayCaster::new(device, queue, OFFSCREEN_FORMAT)?;
    scene.load_into(&mut ray_caster, settings.mode)?;
    target.capture(&mut ray_caster, camera, settings)
}

/// Renders `scene` into a PNG at `path`, written whole or not at all.
pub fn render_png(
    path: &Path,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    size: [u32; 2],
) -> Result<(), RenderError> {
    let image = render_to_image(device, queue, scene, camera, settings, size)?;
    write_png(path, &image)
}

/// Writes `image` as a PNG at `path` through a temporary file and a rename.
pub fn write_png(path: &Path, image: &image::RgbaImage) -> Result<(), RenderError> {
    crate::atomic_file::write_atomically(path, |writer| {
        image.write_to(writer, image::ImageFormat::Png).map_err(std::io::Error::other)
    })
    .map_err(|source| RenderError::WriteImage { source, path: path.to_path_buf() })
}
