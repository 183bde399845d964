//! GPU acquisition for headless use: an adapter, and a device with the limits the ray caster
//! needs.
//!
//! The kiosk UI gets its device from Slint instead and hands it to [`super::RayCaster::new`];
//! this module serves the command line, tests and benchmarks, which draw with no surface.
//! Entry point: [`acquire`].
//!
//! Limits: [`wgpu::Limits::downlevel_defaults`] (what GLES 3 and lavapipe offer) with one
//! change: `max_texture_dimension_3d` is raised to the adapter's own (downlevel says 256; the
//! renderer needs at least [`MIN_TEXTURE_DIMENSION_3D`] for 512^3 volumes, and takes all the
//! adapter offers so larger ones fit where possible).
//!
//! Never: creates a surface or a window, or picks a GPU by name.

use super::RenderError;

/// The smallest `max_texture_dimension_3d` accepted: volumes of 512^3 must fit.
pub const MIN_TEXTURE_DIMENSION_3D: u32 = 512;

/// A device and its queue, with a description of the adapter behind them.
#[derive(Debug, Clone)]
pub struct Gpu {
    /// The adapter's name, vendor, driver and backend.
    pub adapter_info: wgpu::AdapterInfo,
    /// The open device.
    pub device: wgpu::Device,
    /// The device's command queue.
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)", for logs and test messages.
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?})", self.adapter_info.name, self.adapter_info.backend)
    }
}

/// Finds an adapter and opens a device on it. Blocks until done.
///
/// Tries Vulkan, Metal and DX12 first, then OpenGL (whose EGL probing prints noise on
/// machines without a display); `WGPU_BACKEND` (e.g. `vulkan`, `gl`) overrides the choice.
pub fn acquire() -> Result<Gpu, RenderError> {
    pollster::block_on(acquire_async())
}

async fn request_adapter(backends: wgpu::Backends) -> Result<wgpu::Adapter, wgpu::RequestAdapterError> {
    let descriptor = wgpu::InstanceDescriptor { backends, ..wgpu::InstanceDescriptor::new_without_display_handle() };
    let instance = wgpu::Instance::new(descriptor.with_env());
    let options =
        wgpu::RequestAdapterOptions { power_preference: wgpu::PowerPreference::HighPerformance, ..Default::default() };
    instance.request_adapter(&options).await
}

async fn acquire_async() -> Result<Gpu, RenderError> {
    let adapter = match request_adapter(wgpu::Backends::PRIMARY).await {
        Ok(adapter) => adapter,
        Err(_) => request_adapter(wgpu::Backends::all())
            .await
            .map_err(|error| RenderError::NoAdapter { reason: error.to_string() })?,
    };
    let adapter_info = adapter.get_info();
    let adapter_name = format!("{} ({:?})", adapter_info.name, adapter_info.backend);
    let required_limits = required_limits(&adapter.limits(), &adapter_name)?;
    let descriptor = wgpu::DeviceDescriptor {
        label: Some("volasso render device"),
        required_features: wgpu::Features::empty(),
        required_limits,
        ..Default::default()
    };
    let (device, queue) = adapter
        .request_device(&descriptor)
        .await
        .map_err(|source| RenderError::RequestDevice { adapter: adapter_name.clone(), source })?;
    log::info!("rendering on {adapter_name}");
    Ok(Gpu { adapter_info, device, queue })
}

/// The limits to request from an adapter offering `adapter_limits`; see the module doc.
pub fn required_limits(adapter_limits: &wgpu::Limits, adapter_name: &str) -> Result<wgpu::Limits, RenderError> {
    check_texture_dimension_3d(adapter_limits, adapter_name)?;
    Ok(wgpu::Limits {
        max_texture_dimension_3d: adapter_limits.max_texture_dimension_3d,
        ..wgpu::Limits::downlevel_defaults()
    })
}

/// Refuses devices whose 3-D textures cannot hold a 512^3 volume.
pub(crate) fn check_texture_dimension_3d(limits: &wgpu::Limits, adapter_name: &str) -> Result<(), RenderError> {
    if limits.max_texture_dimension_3d < MIN_TEXTURE_DIMENSION_3D {
        return Err(RenderError::LimitTooLow {
            limit: "max_texture_dimension_3d",
            required: MIN_TEXTURE_DIMENSION_3D as u64,
            available: limits.max_texture_dimension_3d as u64,
            adapter: adapter_name.to_string(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_keep_the_adapters_3d_size_and_refuse_small_ones() {
        let adapter = wgpu::Limits { max_texture_dimension_3d: 2048, ..wgpu::Limits::downlevel_defaults() };
        let limits = required_limits(&adapter, "test").unwrap();
        assert_eq!(limits.max_texture_dimension_3d, 2048);
        assert_eq!(
            limits.max_uniform_buffer_binding_size,
            wgpu::Limits::downlevel_defaults().max_uniform_buffer_binding_size
        );
        let small = wgpu::Limits::downlevel_defaults();
        assert!(matches!(required_limits(&small, "test"), Err(RenderError::LimitTooLow { available: 256, .. })));
    }

    #[test]
    fn the_missing_adapter_message_names_the_driver_package() {
        let message = RenderError::NoAdapter { reason: "none".into() }.to_string();
        assert!(message.contains("apt-get install mesa-vulkan-drivers"), "{message}");
    }

    #[test]
    fn acquire_finds_a_device_with_the_limits_it_asked_for() {
        let gpu = crate::render::test_support::gpu();
        eprintln!("render tests run on {}", gpu.adapter_name());
        assert!(gpu.device.limits().max_texture_dimension_3d >= MIN_TEXTURE_DIMENSION_3D, "{}", gpu.adapter_name());
    }
}
