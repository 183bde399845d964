//! The ray caster's bind group layout and bind group: bindings 0-8 of `shaders/raycast.wgsl`
//! (the frame's parameters and the class table as read-only storage, the volume textures and the sampler).
//!
//! Never: creates or uploads textures (the ray caster hands over their views).

use super::super::uniforms::{ClassEntry, RenderUniforms};

/// The texture views bound at bindings 2-6 and 8.
pub(super) struct BoundViews<'a> {
    pub scalar: &'a wgpu::TextureView,
    pub labels: &'a wgpu::TextureView,
    pub rgba: &'a wgpu::TextureView,
    pub rgba_bricks: &'a wgpu::TextureView,
    pub label_bricks: &'a wgpu::TextureView,
    pub cells: &'a wgpu::TextureView,
}

pub(super) fn create_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    uniform_buffer: &wgpu::Buffer,
    class_table_buffer: &wgpu::Buffer,
    views: &BoundViews,
    sampler: &wgpu::Sampler,
) -> wgpu::BindGroup {
    let texture = |binding, view| wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) };
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("ray caster bind group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: uniform_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: class_table_buffer.as_entire_binding() },
            texture(2, views.scalar),
            texture(3, views.labels),
            texture(4, views.rgba),
            texture(5, views.rgba_bricks),
            texture(6, views.label_bricks),
            wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::Sampler(sampler) },
            texture(8, views.cells),
        ],
    })
}

/// Bindings 0-8 of `raycast.wgsl`, all for the fragment stage.
pub(super) fn create_bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // Read-only storage rather than uniform buffers: see the bindings in raycast.wgsl.
    let read_only = |binding, size: usize| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size as u64),
        },
        count: None,
    };
    let texture = |binding, sample_type| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
        count: None,
    };
    let filterable = wgpu::TextureSampleType::Float { filterable: true };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("ray caster bind group layout"),
        entries: &[
            read_only(0, std::mem::size_of::<RenderUniforms>()),
            read_only(1, std::mem::size_of::<ClassEntry>() * super::super::uniforms::CLASS_TABLE_SIZE),
            texture(2, filterable),
            texture(3, wgpu::TextureSampleType::Uint),
            texture(4, filterable),
            texture(5, wgpu::TextureSampleType::Uint),
            texture(6, wgpu::TextureSampleType::Uint),
            wgpu::BindGroupLayoutEntry {
                binding: 7,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            texture(8, wgpu::TextureSampleType::Uint),
        ],
    })
}
