//! 3-D textures for the ray caster, uploaded in z-slabs through one reused staging buffer, so
//! the CPU never holds a second full copy of a volume.
//!
//! Formats:
//! * scalar volume: `R8Unorm` for unscaled `uint8` data (its bytes go up as they are),
//!   otherwise `R16Float` holding `(value - min) / (max - min)` (16-bit and wider types,
//!   scaled data; 11 significant bits, about 2 HU over the whole CT range). Both are
//!   filterable on every adapter, unlike `R32Float`. The shader maps texels back to physical
//!   values with `value_min + texel * value_span`, so gradients keep their units.
//! * labels: `R8Uint`, read with `textureLoad` (never filtered; see `LabelInterpolation`).
//! * pre-classified RGBA: `Rgba8Unorm` with opacity-weighted (premultiplied) colours: the
//!   input is straight alpha, and premultiplying each voxel before trilinear filtering keeps
//!   the colour of transparent neighbours (black, from `ClassStyle::rgba`) from darkening
//!   borders (Wittenbrink, Malzbender & Goss 1998).
//! * brick occupancy: `R8Uint`, one texel per brick (see [`super::bricks`]).
//! * label cells: `R8Uint`, one code per cell of eight labels (see [`super::cells`]).
//!
//! Never: keeps data on the CPU after an upload, or filters anything itself.

use super::RenderError;
use crate::volume::{Volume, VoxelType};

/// Voxels and their spacing: the shape of the box the ray caster draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeGeometry {
    /// Size in voxels, (x, y, z).
    pub dims: [usize; 3],
    /// Voxel spacing along x, y and z, in mm.
    pub spacing_mm: [f64; 3],
}

impl VolumeGeometry {
    /// The geometry of `volume`.
    pub fn of(volume: &Volume) -> VolumeGeometry {
        VolumeGeometry { dims: volume.dims, spacing_mm: volume.spacing_mm }
    }

    /// Voxels in the box.
    pub fn voxel_count(&self) -> usize {
        self.dims.iter().product()
    }
}

/// A 3-D texture, its default view, and the geometry it was made for.
#[derive(Debug)]
pub struct VolumeTexture {
    /// The 3-D texture.
    pub texture: wgpu::Texture,
    /// Its default view, as bound to the shader.
    pub view: wgpu::TextureView,
    /// The volume it holds.
    pub geometry: VolumeGeometry,
}

/// The scalar volume's texture and the map from texels back to physical values.
#[derive(Debug)]
pub struct ScalarTexture {
    /// The texture, `R8Unorm` or `R16Float`.
    pub volume: VolumeTexture,
    /// Physical value of texel 0.
    pub value_min: f32,
    /// Physical value range texels 0 to 1 cover.
    pub value_span: f32,
}

/// Staging slabs are about this large: big enough to keep the queue busy, small enough not
/// to matter next to the volume.
const SLAB_BYTES: usize = 8 << 20;

pub(super) fn create_texture(
    device: &wgpu::Device,
    label: &str,
    what: &'static str,
    dims: [usize; 3],
    format: wgpu::TextureFormat,
) -> Result<VolumeTexture, RenderError> {
    let max_dimension = device.limits().max_texture_dimension_3d;
    if dims.iter().any(|&d| d == 0 || d > max_dimension as usize) {
        return Err(RenderError::VolumeTooLarge { what, dims, max_dimension });
    }
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: dims[0] as u32, height: dims[1] as u32, depth_or_array_layers: dims[2] as u32 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D3,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let view = texture.create_view(&wgpu::TextureViewDescriptor { label: Some(label), ..Default::default() });
    Ok(VolumeTexture { texture, view, geometry: VolumeGeometry { dims, spacing_mm: [1.0; 3] } })
}

/// A 1x1x1 zero texture bound where no data was set yet (bind groups need every binding).
pub fn placeholder(device: &wgpu::Device, label: &str, format: wgpu::TextureFormat) -> VolumeTexture {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D3,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let view = texture.create_view(&wgpu::TextureViewDescriptor { label: Some(label), ..Default::default() });
    VolumeTexture { texture, view, geometry: VolumeGeometry { dims: [1; 3], spacing_mm: [1.0; 3] } }
}

/// Z-slices per slab for slices of `slice_bytes` bytes.
pub(super) fn slices_per_slab(slice_bytes: usize) -> usize {
    (SLAB_BYTES / slice_bytes.max(1)).max(1)
}

/// Writes z-slices `slab` from `bytes` (tightly packed rows), then
/// submits and waits: `write_texture` stages its bytes until the next submit, so without this
/// the staging copies of all slabs would add up to a second copy of the volume.
pub(super) fn write_slab(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    dims: [usize; 3],
    bytes_per_voxel: usize,
    slab: std::ops::Range<usize>,
    bytes: &[u8],
) -> Result<(), RenderError> {
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d { x: 0, y: 0, z: slab.start as u32 },
            aspect: wgpu::TextureAspect::All,
        },
        bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some((dims[0] * bytes_per_voxel) as u32),
            rows_per_image: Some(dims[1] as u32),
        },
        wgpu::Extent3d { width: dims[0] as u32, height: dims[1] as u32, depth_or_array_layers: slab.len() as u32 },
    );
    let submission = queue.submit([]);
    device
        .poll(wgpu::PollType::Wait { submission_index: Some(submission), timeout: None })
        .map(|_| ())
        .map_err(|error| RenderError::Device { problem: error.to_string() })
}

/// Uploads the scalar volume (see the module doc for the format).
pub fn upload_scalar(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    volume: &Volume,
) -> Result<ScalarTexture, RenderError> {
    let dims = volume.dims;
    let plane = dims[0] * dims[1];
    if volume.voxel_type == VoxelType::U8 && volume.scale.is_identity() {
        let mut texture =
            create_texture(device, "scalar volume (R8Unorm)", "scalar", dims, wgpu::TextureFormat::R8Unorm)?;
        let bytes = volume.raw_bytes();
        let step = slices_per_slab(plane);
        for z in (0..dims[2]).step_by(step) {
            let slices = step.min(dims[2] - z);
            write_slab(
                device,
                queue,
                &texture.texture,
                dims,
                1,
                z..z + slices,
                &bytes[z * plane..(z + slices) * plane],
            )?;
        }
        texture.geometry = VolumeGeometry::of(volume);
        return Ok(ScalarTexture { volume: texture, value_min: 0.0, value_span: 255.0 });
    }
    let mut texture =
        create_texture(device, "scalar volume (R16Float)", "scalar", dims, wgpu::TextureFormat::R16Float)?;
    let range = volume.value_range();
    let value_min = range.min as f32;
    let value_span = if range.max > range.min { (range.max - range.min) as f32 } else { 1.0 };
    let step = slices_per_slab(plane * 2);
    let mut values = vec![0f32; step * plane];
    let mut staging = vec![0u8; step * plane * 2];
    for z in (0..dims[2]).step_by(step) {
        let slices = step.min(dims[2] - z);
        let count = slices * plane;
        volume.read_f32(z * plane, &mut values[..count]);
        for (value, out) in values[..count].iter().zip(staging.chunks_exact_mut(2)) {
            // NaN and infinities (counted in the value range) are drawn as the minimum.
            let normalised = if value.is_finite() { ((value - value_min) / value_span).clamp(0.0, 1.0) } else { 0.0 };
            out.copy_from_slice(&half::f16::from_f32(normalised).to_le_bytes());
        }
        write_slab(device, queue, &texture.texture, dims, 2, z..z + slices, &staging[..count * 2])?;
    }
    texture.geometry = VolumeGeometry::of(volume);
    Ok(ScalarTexture { volume: texture, value_min, value_span })
}

/// Uploads a label volume (one `u8` per voxel, x fastest) of `geometry`.
pub fn upload_labels(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    geometry: VolumeGeometry,
    labels: &[u8],
) -> Result<VolumeTexture, RenderError> {
    let dims = geometry.dims;
    check_size("label volume", dims, geometry.voxel_count(), labels.len())?;
    let mut texture = create_texture(device, "label volume (R8Uint)", "label", dims, wgpu::TextureFormat::R8Uint)?;
    let plane = dims[0] * dims[1];
    let step = slices_per_slab(plane);
    for z in (0..dims[2]).step_by(step) {
        let slices = step.min(dims[2] - z);
        write_slab(device, queue, &texture.texture, dims, 1, z..z + slices, &labels[z * plane..(z + slices) * plane])?;
    }
    texture.geometry = geometry;
    Ok(texture)
}

/// Uploads a straight-alpha RGBA8 volume of `geometry`, premultiplying it slab by slab.
pub fn upload_rgba(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    geometry: VolumeGeometry,
    rgba: &[u8],
) -> Result<VolumeTexture, RenderError> {
    let dims = geometry.dims;
    check_size("RGBA volume", dims, 4 * geometry.voxel_count(), rgba.len())?;
    let mut texture = create_texture(
        device,
        "pre-classified volume (Rgba8Unorm, premultiplied)",
        "RGBA",
        dims,
        wgpu::TextureFormat::Rgba8Unorm,
    )?;
    let plane_bytes = 4 * dims[0] * dims[1];
    let step = slices_per_slab(plane_bytes);
    let mut staging = vec![0u8; step * plane_bytes];
    for z in (0..dims[2]).step_by(step) {
        let slices = step.min(dims[2] - z);
        let source = &rgba[z * plane_bytes..(z + slices) * plane_bytes];
        for (voxel, out) in source.chunks_exact(4).zip(staging.chunks_exact_mut(4)) {
            let alpha = voxel[3] as u32;
            for channel in 0..3 {
                out[channel] = ((voxel[channel] as u32 * alpha + 127) / 255) as u8;
            }
            out[3] = voxel[3];
        }
        write_slab(device, queue, &texture.texture, dims, 4, z..z + slices, &staging[..source.len()])?;
    }
    texture.geometry = geometry;
    Ok(texture)
}

/// Uploads a brick occupancy grid (one byte per brick, x fastest).
pub fn upload_bricks(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    brick_dims: [usize; 3],
    occupancy: &[u8],
) -> Result<VolumeTexture, RenderError> {
    check_size("brick occupancy", brick_dims, brick_dims.iter().product(), occupancy.len())?;
    let texture = create_texture(device, label, "brick occupancy", brick_dims, wgpu::TextureFormat::R8Uint)?;
    write_slab(device, queue, &texture.texture, brick_dims, 1, 0..brick_dims[2], occupancy)?;
    Ok(texture)
}

pub(super) fn check_size(
    what: &'static str,
    dims: [usize; 3],
    expected: usize,
    found: usize,
) -> Result<(), RenderError> {
    if expected != found {
        return Err(RenderError::DataSize { what, dims, expected, found });
    }
    Ok(())
}
