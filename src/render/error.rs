//! The one error type of the render stage.

use std::path::PathBuf;

/// Everything that can go wrong between a volume on the CPU and pixels in a texture or PNG.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(
        "no GPU adapter was found ({reason}); on a machine without a GPU install Mesa's software \
         Vulkan driver lavapipe: apt-get install mesa-vulkan-drivers libvulkan1"
    )]
    NoAdapter { reason: String },

    #[error("the GPU adapter {adapter} refused a device: {source}")]
    RequestDevice {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },

    #[error("the GPU limit {limit} is {available}, the renderer needs at least {required} (adapter {adapter})")]
    LimitTooLow { limit: &'static str, required: u64, available: u64, adapter: String },

    #[error(
        "the {what} volume is {dims:?} voxels, but this GPU holds 3-D textures of at most {max_dimension} \
         voxels along an axis"
    )]
    VolumeTooLarge { what: &'static str, dims: [usize; 3], max_dimension: u32 },

    #[error("the {what} has {found} bytes, expected {expected} for a {dims:?} volume")]
    DataSize { what: &'static str, dims: [usize; 3], expected: usize, found: usize },

    #[error("the class table has {classes} classes; labels are 8-bit, so at most {max} fit")]
    TooManyClasses { classes: usize, max: usize },

    #[error("{mode:?} rendering needs {missing}, which was never set")]
    MissingInput { mode: super::RenderMode, missing: &'static str },

    #[error("the labels were set for a {labels:?} volume, but the scalar volume is {volume:?}")]
    GeometryMismatch { labels: [usize; 3], volume: [usize; 3] },

    #[error("render setting {name} = {value} is out of range ({expected})")]
    BadSetting { name: &'static str, value: String, expected: &'static str },

    #[error("headless rendering needs an Rgba8Unorm ray caster, this one renders to {found:?}")]
    WrongTargetFormat { found: wgpu::TextureFormat },

    #[error("the GPU device failed: {problem}")]
    Device { problem: String },

    #[error("reading the rendered image back from the GPU failed: {problem}")]
    ReadBack { problem: String },

    #[error("writing the image failed: {source}: {path}")]
    WriteImage {
        #[source]
        source: std::io::Error,
        path: PathBuf,
    },
}
