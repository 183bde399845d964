//! The one error type of the render stage.

use std::path::PathBuf;

/// Everything that can go wrong between a volume on the CPU and pixels in a texture or PNG.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// wgpu found no usable GPU adapter, not even a software one.
    #[error(
        "no GPU adapter was found ({reason}); on a machine without a GPU install Mesa's software \
         Vulkan driver lavapipe: apt-get install mesa-vulkan-drivers libvulkan1"
    )]
    NoAdapter {
        /// What the adapter request reported.
        reason: String,
    },

    /// The adapter was found but would not open a device.
    #[error("the GPU adapter {adapter} refused a device: {source}")]
    RequestDevice {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason.
        #[source]
        source: wgpu::RequestDeviceError,
    },

    /// The adapter's limits are below what the renderer needs.
    #[error("the GPU limit {limit} is {available}, the renderer needs at least {required} (adapter {adapter})")]
    LimitTooLow {
        /// The wgpu limit's name.
        limit: &'static str,
        /// The smallest value the renderer works with.
        required: u64,
        /// The adapter's value.
        available: u64,
        /// The adapter's name.
        adapter: String,
    },

    /// A volume has more voxels along an axis than the GPU's 3-D textures hold.
    #[error(
        "the {what} volume is {dims:?} voxels, but this GPU holds 3-D textures of at most {max_dimension} \
         voxels along an axis"
    )]
    VolumeTooLarge {
        /// Which volume (scalar, label, RGBA).
        what: &'static str,
        /// Its size in voxels, (x, y, z).
        dims: [usize; 3],
        /// The GPU's largest 3-D texture side, in voxels.
        max_dimension: u32,
    },

    /// A voxel buffer's length does not match its dimensions.
    #[error("the {what} has {found} bytes, expected {expected} for a {dims:?} volume")]
    DataSize {
        /// Which buffer.
        what: &'static str,
        /// The volume's size in voxels, (x, y, z).
        dims: [usize; 3],
        /// The length the dimensions call for, in bytes.
        expected: usize,
        /// The buffer's length, in bytes.
        found: usize,
    },

    /// The class table has more classes than an 8-bit label can name.
    #[error("the class table has {classes} classes; labels are 8-bit, so at most {max} fit")]
    TooManyClasses {
        /// Classes in the table.
        classes: usize,
        /// The most the label texture holds.
        max: usize,
    },

    /// The render mode needs an input (volume, labels, transfer table) that was never uploaded.
    #[error("{mode:?} rendering needs {missing}, which was never set")]
    MissingInput {
        /// The mode asked for.
        mode: super::RenderMode,
        /// The input it lacks.
        missing: &'static str,
    },

    /// The label volume and the scalar volume differ in size.
    #[error("the labels were set for a {labels:?} volume, but the scalar volume is {volume:?}")]
    GeometryMismatch {
        /// The label volume's size in voxels.
        labels: [usize; 3],
        /// The scalar volume's size in voxels.
        volume: [usize; 3],
    },

    /// A render setting is outside its valid range.
    #[error("render setting {name} = {value} is out of range ({expected})")]
    BadSetting {
        /// The setting's name.
        name: &'static str,
        /// The value given, as text.
        value: String,
        /// The valid range, in words.
        expected: &'static str,
    },

    /// Headless rendering was given a ray caster that does not render to `Rgba8Unorm`.
    #[error("headless rendering needs an Rgba8Unorm ray caster, this one renders to {found:?}")]
    WrongTargetFormat {
        /// The ray caster's target format.
        found: wgpu::TextureFormat,
    },

    /// The GPU device reported an error (lost, out of memory, validation).
    #[error("the GPU device failed: {problem}")]
    Device {
        /// wgpu's description.
        problem: String,
    },

    /// Mapping the rendered texture back to the CPU failed.
    #[error("reading the rendered image back from the GPU failed: {problem}")]
    ReadBack {
        /// wgpu's description.
        problem: String,
    },

    /// Saving the rendered image failed.
    #[error("writing the image failed: {source}: {path}")]
    WriteImage {
        /// The underlying I/O or encoding error.
        #[source]
        source: std::io::Error,
        /// The image file.
        path: PathBuf,
    },
}
