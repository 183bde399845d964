//! [`RayCaster`]: the GPU job that draws a volume into a texture view, frame by frame.
//!
//! It owns every GPU resource it uses, created in [`RayCaster::new`] in this order, each
//! labelled: (1) the uniform buffer and the class-table buffer, (2) placeholder volume
//! textures and the sampler, (3) the bind group layout, pipeline layout, shader module and
//! render pipeline, (4) the bind group. The `set_*` methods upload data (in slabs, see
//! [`super::volume_texture`]) and rebuild the bind group; [`RayCaster::render`] writes the
//! frame's uniforms and records one render pass into the caller's encoder, nothing else, so
//! the kiosk UI can call it from Slint's rendering notifier on Slint's own device.
//!
//! Shader: `shaders/raycast.wgsl` (its top comment names the Rust twins).
//!
//! Never: submits work, reads back, or knows about windows, Slint or files.

use super::bricks::LabelBricks;
use super::uniforms::{ClassEntry, FrameVolume, RenderUniforms, class_table, visible_labels};
use super::volume_texture::{self, ScalarTexture, VolumeGeometry, VolumeTexture};
use super::{Camera, RenderError, RenderMode, RenderSettings, bricks};
use crate::transfer::ClassStyle;
use crate::volume::Volume;
use bindings::{BoundViews, create_bind_group, create_bind_group_layout};

/// The ray casting shader, compiled into the binary.
pub const SHADER_SOURCE: &str = include_str!("../../../../shaders/raycast.wgsl");

/// A rectangle of pixels of a frame, from its top-left corner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRegion {
    /// Left edge, in pixels from the frame's left.
    pub x: u32,
    /// Top edge, in pixels from the frame's top.
    pub y: u32,
    /// Width, in pixels.
    pub width: u32,
    /// Height, in pixels.
    pub height: u32,
}

impl PixelRegion {
    /// Whether the region is non-empty and inside a frame of `size` pixels.
    pub fn fits(&self, size: [u32; 2]) -> bool {
        let inside =
            |start: u32, length: u32, side: u32| length > 0 && start.checked_add(length).is_some_and(|end| end <= side);
        inside(self.x, self.width, size[0]) && inside(self.y, self.height, size[1])
    }
}

/// The largest per-class opacity factor ([`RayCaster::set_class_opacity`]): enough to make
/// the faintest default class opaque within a few samples, small enough to keep a slider usable.
pub const MAX_CLASS_OPACITY_FACTOR: f32 = 8.0;

/// Draws a volume with front-to-back ray casting; see the module doc.
pub struct RayCaster {
    device: wgpu::Device,
    queue: wgpu::Queue,
    target_format: wgpu::TextureFormat,
    viewport_size: [u32; 2],

    uniform_buffer: wgpu::Buffer,
    class_table_buffer: wgpu::Buffer,

    scalar_texture: Option<ScalarTexture>,
    label_texture: Option<VolumeTexture>,
    rgba_texture: Option<VolumeTexture>,
    rgba_brick_texture: Option<VolumeTexture>,
    label_brick_texture: Option<VolumeTexture>,
    /// The label of each cell of eight labels that agree (see [`super::cells`]).
    cell_texture: Option<VolumeTexture>,
    /// Bound wherever a float texture is not set yet.
    placeholder_float_texture: VolumeTexture,
    /// Bound wherever an integer texture is not set yet.
    placeholder_uint_texture: VolumeTexture,
    sampler: wgpu::Sampler,

    bind_group_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,

    /// The per-label table as last uploaded (label 0 first).
    class_table: Vec<ClassEntry>,
    /// The styles behind `class_table` (class k is `class_styles[k - 1]`).
    class_styles: Vec<ClassStyle>,
    /// Which labels occur in each brick, kept to re-derive occupancy when visibility changes.
    label_bricks: Option<LabelBricks>,
}

impl RayCaster {
    /// Creates every GPU resource for drawing into views of `target_format` (for the UI:
    /// `Rgba8Unorm` or `Rgba8UnormSrgb`, with `RENDER_ATTACHMENT | TEXTURE_BINDING`).
    /// The device must allow 3-D textures of at least 512 texels per side
    /// (see [`super::gpu::required_limits`]).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target_format: wgpu::TextureFormat,
    ) -> Result<RayCaster, RenderError> {
        super::gpu::check_texture_dimension_3d(&device.limits(), "the given device")?;

        // 1. Buffers.
        let uniform_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ray caster uniforms"),
            size: std::mem::size_of::<RenderUniforms>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let class_table = class_table(&[])?;
        let class_table_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ray caster class table"),
            size: std::mem::size_of_val(class_table.as_slice()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(&class_table_buffer, 0, bytemuck::cast_slice(&class_table));

        // 2. Placeholder textures and the sampler.
        let placeholder_float_texture =
            volume_texture::placeholder(device, "placeholder volume (float)", wgpu::TextureFormat::R8Unorm);
        let placeholder_uint_texture =
            volume_texture::placeholder(device, "placeholder volume (uint)", wgpu::TextureFormat::R8Uint);
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("trilinear volume sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });

        // 3. Layouts, shader and pipeline.
        let bind_group_layout = create_bind_group_layout(device);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ray caster pipeline layout"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shaders/raycast.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SHADER_SOURCE.into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("ray caster pipeline"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vertex_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fragment_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: target_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });

        // 4. The bind group, over placeholders until data arrives.
        let placeholder_views = BoundViews {
            scalar: &placeholder_float_texture.view,
            labels: &placeholder_uint_texture.view,
            rgba: &placeholder_float_texture.view,
            rgba_bricks: &placeholder_uint_texture.view,
            label_bricks: &placeholder_uint_texture.view,
            cells: &placeholder_uint_texture.view,
        };
        let bind_group = create_bind_group(
            device,
            &bind_group_layout,
            &uniform_buffer,
            &class_table_buffer,
            &placeholder_views,
            &sampler,
        );
        Ok(RayCaster {
            device: device.clone(),
            queue: queue.clone(),
            target_format,
            viewport_size: [1, 1],
            uniform_buffer,
            class_table_buffer,
            scalar_texture: None,
            label_texture: None,
            rgba_texture: None,
            rgba_brick_texture: None,
            label_brick_texture: None,
            cell_texture: None,
            placeholder_float_texture,
            placeholder_uint_texture,
            sampler,
            bind_group_layout,
            pipeline,
            bind_group,
            class_table,
            class_styles: Vec::new(),
            label_bricks: None,
        })
    }

    /// The format of the views this ray caster draws into.
    pub fn target_format(&self) -> wgpu::TextureFormat {
        self.target_format
    }

    /// Uploads the scalar volume; labels set for another shape are dropped.
    pub fn set_volume(&mut self, volume: &Volume) -> Result<(), RenderError> {
        let scalar = volume_texture::upload_scalar(&self.device, &self.queue, volume)?;
        if self.label_texture.as_ref().is_some_and(|labels| labels.geometry != scalar.volume.geometry) {
            self.label_texture = None;
            self.label_brick_texture = None;
            self.cell_texture = None;
            self.label_bricks = None;
        }
        self.scalar_texture = Some(scalar);
        self.rebuild_bind_group();
        Ok(())
    }

    /// Uploads the label volume (one byte per voxel of the scalar volume, x fastest; 0 is
    /// background, k is class k of the table).
    pub fn set_labels(&mut self, labels: &[u8]) -> Result<(), RenderError> {
        let geometry = self.scalar_geometry().ok_or(RenderError::MissingInput {
            mode: RenderMode::Postclassified,
            missing: "a scalar volume (call set_volume before set_labels)",
        })?;
        let texture = volume_texture::upload_labels(&self.device, &self.queue, geometry, labels)?;
        let cells = super::cells::upload_cells(&self.device, &self.queue, geometry, labels)?;
        let label_bricks = LabelBricks::new(geometry.dims, labels);
        let occupancy = label_bricks.occupancy(&visible_labels(&self.class_table));
        self.label_brick_texture = Some(volume_texture::upload_bricks(
            &self.device,
            &self.queue,
            "label brick occupancy",
            label_bricks.brick_dims,
            &occupancy,
        )?);
        self.label_bricks = Some(label_bricks);
        self.label_texture = Some(texture);
        self.cell_texture = Some(cells);
        self.rebuild_bind_group();
        Ok(())
    }

    /// Replaces the class table: class k (1-based, as in the label volume) is `styles[k - 1]`.
    /// Cheap: changing visibility or emphasis only rewrites the table and brick occupancy.
    pub fn set_class_table(&mut self, styles: &[ClassStyle]) -> Result<(), RenderError> {
        self.class_table = class_table(styles)?;
        self.class_styles = styles.to_vec();
        self.queue.write_buffer(&self.class_table_buffer, 0, bytemuck::cast_slice(&self.class_table));
        if let Some(label_bricks) = &self.label_bricks {
            let occupancy = label_bricks.occupancy(&visible_labels(&self.class_table));
            self.label_brick_texture = Some(volume_texture::upload_bricks(
                &self.device,
                &self.queue,
                "label brick occupancy",
                label_bricks.brick_dims,
                &occupancy,
            )?);
            self.rebuild_bind_group();
        }
        Ok(())
    }

    /// Per-class opacity (the UI's slider): class `label` (1-based) is drawn with its opacity
    /// times `factor` (its [`ClassStyle::emphasis`]): 1 is the default rule's opacity, 0 hides
    /// the class (and lets empty-space skipping pass its bricks), up to
    /// [`MAX_CLASS_OPACITY_FACTOR`]. Post-classification only: the pre-classified RGBA volume
    /// bakes opacities in and must be rebuilt from the styles ([`Self::class_styles`]).
    pub fn set_class_opacity(&mut self, label: u8, factor: f32) -> Result<(), RenderError> {
        if !(0.0..=MAX_CLASS_OPACITY_FACTOR).contains(&factor) {
            return Err(RenderError::BadSetting {
                name: "class opacity factor",
                value: factor.to_string(),
                expected: "a number from 0 to MAX_CLASS_OPACITY_FACTOR",
            });
        }
        let Some(style) = usize::from(label).checked_sub(1).and_then(|index| self.class_styles.get(index)) else {
            return Err(RenderError::BadSetting {
                name: "class label",
                value: label.to_string(),
                expected: "a class of the table (1 to the number of classes)",
            });
        };
        let mut styles = self.class_styles.clone();
        styles[usize::from(label) - 1] = ClassStyle { emphasis: factor, ..style.clone() };
        self.set_class_table(&styles)
    }

    /// The opacity factor of class `label` ([`Self::set_class_opacity`]), if it is a class of
    /// the table.
    pub fn class_opacity(&self, label: u8) -> Option<f32> {
        usize::from(label).checked_sub(1).and_then(|index| self.class_styles.get(index)).map(|style| style.emphasis)
    }

    /// The class styles as last set (class k is element k - 1), opacity factors included.
    pub fn class_styles(&self) -> &[ClassStyle] {
        &self.class_styles
    }

    /// Uploads the pre-classified volume: 4 bytes per voxel (straight-alpha RGBA, x fastest)
    /// of a volume shaped `geometry`.
    pub fn set_rgba(&mut self, geometry: VolumeGeometry, rgba: &[u8]) -> Result<(), RenderError> {
        let texture = volume_texture::upload_rgba(&self.device, &self.queue, geometry, rgba)?;
        let occupancy = bricks::rgba_occupancy(geometry.dims, rgba);
        self.rgba_brick_texture = Some(volume_texture::upload_bricks(
            &self.device,
            &self.queue,
            "RGBA brick occupancy",
            bricks::brick_dims(geometry.dims),
            &occupancy,
        )?);
        self.rgba_texture = Some(texture);
        self.rebuild_bind_group();
        Ok(())
    }

    /// Sets the size in pixels of the views [`RayCaster::render`] draws into.
    pub fn resize(&mut self, width_pixels: u32, height_pixels: u32) {
        self.viewport_size = [width_pixels.max(1), height_pixels.max(1)];
    }

    /// The size set by [`RayCaster::resize`].
    pub fn viewport_size(&self) -> [u32; 2] {
        self.viewport_size
    }

    /// Records one frame into `encoder`, drawing every pixel of `target` (a view of the
    /// size given to [`RayCaster::resize`], in the target format). Writes the frame's uniforms
    /// through the queue, so each `render` needs its own submit before the next one.
    pub fn render(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<(), RenderError> {
        self.render_region(encoder, target, camera, settings, None)
    }

    /// [`render`](Self::render) limited to `region` of the frame (`None`: all of it), leaving
    /// the other pixels of `target` as they are. The rays are those of the whole frame, so a
    /// frame drawn in regions is the frame drawn at once, pixel for pixel (progressive
    /// rendering draws full frames in bands it can abandon).
    pub fn render_region(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        camera: &Camera,
        settings: &RenderSettings,
        region: Option<PixelRegion>,
    ) -> Result<(), RenderError> {
        settings.validate()?;
        let frame_volume = self.frame_volume(settings.mode)?;
        let target_size = target.texture().size();
        if [target_size.width, target_size.height] != self.viewport_size {
            return Err(RenderError::BadSetting {
                name: "target size",
                value: format!("{}x{}", target_size.width, target_size.height),
                expected: "the size given to RayCaster::resize",
            });
        }
        let extent_mm: [f32; 3] =
            std::array::from_fn(|a| (frame_volume.dims[a] as f64 * frame_volume.spacing_mm[a]) as f32);
        let rays = camera.view_rays(extent_mm, self.viewport_size[0], self.viewport_size[1]);
        if let Some(region) = region
            && !region.fits(self.viewport_size)
        {
            return Err(RenderError::BadSetting {
                name: "region",
                value: format!("{region:?}"),
                expected: "a non-empty rectangle inside the frame",
            });
        }
        let uniforms =
            RenderUniforms::new(&rays, settings, &frame_volume, self.viewport_size, self.target_format.is_srgb());
        self.queue.write_buffer(&self.uniform_buffer, 0, bytemuck::bytes_of(&uniforms));

        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("ray casting pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    // A region keeps the rest of the frame (the fragment shader writes every
                    // pixel it covers).
                    load: match region {
                        None => wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        Some(_) => wgpu::LoadOp::Load,
                    },
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if let Some(region) = region {
            pass.set_scissor_rect(region.x, region.y, region.width, region.height);
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.draw(0..3, 0..1);
        Ok(())
    }

    /// Marks every label cell mixed, so every sample takes the eight-label path (tests compare
    /// both paths).
    #[cfg(test)]
    pub(crate) fn mark_every_cell_mixed(&mut self) {
        let geometry = self.label_texture.as_ref().map(|labels| labels.geometry).expect("labels are set");
        let mixed = vec![super::cells::MIXED_CELL; geometry.voxel_count()];
        self.cell_texture = Some(super::cells::upload_cells(&self.device, &self.queue, geometry, &mixed).unwrap());
        self.rebuild_bind_group();
    }

    fn scalar_geometry(&self) -> Option<VolumeGeometry> {
        self.scalar_texture.as_ref().map(|scalar| scalar.volume.geometry)
    }

    /// The geometry and value mapping the frame's mode draws, or what is missing for it.
    fn frame_volume(&self, mode: RenderMode) -> Result<FrameVolume, RenderError> {
        let missing = |missing| RenderError::MissingInput { mode, missing };
        match mode {
            RenderMode::Preclassified => {
                let rgba = self.rgba_texture.as_ref().ok_or(missing("an RGBA volume (set_rgba)"))?;
                let geometry = rgba.geometry;
                Ok(FrameVolume {
                    dims: geometry.dims,
                    spacing_mm: geometry.spacing_mm,
                    value_min: 0.0,
                    value_span: 1.0,
                })
            }
            RenderMode::Postclassified => {
                let scalar = self.scalar_texture.as_ref().ok_or(missing("a scalar volume (set_volume)"))?;
                self.label_texture.as_ref().ok_or(missing("a label volume (set_labels)"))?;
                let geometry = scalar.volume.geometry;
                Ok(FrameVolume {
                    dims: geometry.dims,
                    spacing_mm: geometry.spacing_mm,
                    value_min: scalar.value_min,
                    value_span: scalar.value_span,
                })
            }
        }
    }

    fn rebuild_bind_group(&mut self) {
        fn view_or<'a>(texture: Option<&'a VolumeTexture>, placeholder: &'a VolumeTexture) -> &'a wgpu::TextureView {
            &texture.unwrap_or(placeholder).view
        }
        let (float, uint) = (&self.placeholder_float_texture, &self.placeholder_uint_texture);
        let views = BoundViews {
            scalar: view_or(self.scalar_texture.as_ref().map(|scalar| &scalar.volume), float),
            labels: view_or(self.label_texture.as_ref(), uint),
            rgba: view_or(self.rgba_texture.as_ref(), float),
            rgba_bricks: view_or(self.rgba_brick_texture.as_ref(), uint),
            label_bricks: view_or(self.label_brick_texture.as_ref(), uint),
            cells: view_or(self.cell_texture.as_ref(), uint),
        };
        self.bind_group = create_bind_group(
            &self.device,
            &self.bind_group_layout,
            &self.uniform_buffer,
            &self.class_table_buffer,
            &views,
            &self.sampler,
        );
    }
}

mod bindings;

#[cfg(test)]
mod tests;
