//! GPU direct volume rendering with wgpu: the last stage of the pipeline, turning a volume, its
//! labels and the per-class table of §3.5 (or the paper's pre-classified RGBA volume) into
//! pixels.
//!
//! The ray caster ([`RayCaster`], shader `shaders/raycast.wgsl`) composites front to back with
//! opacity corrected for the sample distance, stops rays once opaque, skips empty 8^3 bricks,
//! jitters ray starts per pixel, shades with gradients (switchable), and respects anisotropic
//! spacing: the volume is a box of `dims * spacing_mm` millimetres. Two modes
//! ([`RenderMode`]): pre-classified RGBA, and post-classification from scalar + labels + table,
//! where each sample takes the class with the largest trilinearly weighted indicator among its
//! eight neighbouring labels, so colours never bleed across class borders.
//!
//! Modules: [`gpu`] (device acquisition), [`volume_texture`] (slab uploads), [`bricks`]
//! (empty-space skipping), [`cells`] (one fetch per sample away from class borders),
//! [`camera`], [`settings`], [`uniforms`] (the shader's twins), [`raycast`] ([`RayCaster`]),
//! [`progressive`] (previews sized to a time budget, full frames in bands), [`preclassify`]
//! (the RGBA volume on the CPU), [`headless`]
//! (offscreen rendering to images and PNG files).
//!
//! ```no_run
//! use volasso_core::render::{self, Camera, RenderSettings, headless::Scene};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let volume = volasso_core::volume::open("engine_256x256x256_uint8.raw".as_ref(), &Default::default())?;
//! let labels = vec![1u8; volume.voxel_count()];
//! let styles: Vec<volasso_core::transfer::ClassStyle> = Vec::new(); // from the transfer stage
//! let gpu = render::gpu::acquire()?;
//! let scene = Scene { volume: &volume, labels: &labels, class_styles: &styles, rgba: None };
//! render::headless::render_png(
//!     "engine.png".as_ref(), &gpu.device, &gpu.queue, &scene,
//!     &Camera::default(), &RenderSettings::default(), [800, 600],
//! )?;
//! # Ok(()) }
//! ```
//!
//! Never: imports UI crates, opens windows or surfaces, classifies voxels, or picks colours
//! (that is [`crate::transfer`]).

pub mod bricks;
pub mod camera;
pub mod cells;
pub mod error;
pub mod gpu;
pub mod headless;
pub mod preclassify;
pub mod progressive;
pub mod raycast;
pub mod settings;
pub mod uniforms;
pub mod volume_texture;

#[cfg(test)]
mod looks;
#[cfg(test)]
pub(crate) mod test_support;

pub use camera::{Camera, Projection, ViewRays};
pub use error::RenderError;
pub use gpu::{Gpu, acquire};
pub use raycast::{MAX_CLASS_OPACITY_FACTOR, PixelRegion, RayCaster};
pub use settings::{ClipBox, ClipPlane, LabelInterpolation, Lighting, RenderMode, RenderSettings};
pub use volume_texture::VolumeGeometry;
