//! The Slint platform of the appliance and of the replay harness: Slint's software renderer
//! drawing into memory, with a clock that is either real or advanced by hand. The same
//! renderer then serves a DRM display (the kiosk crate's display), screenshots and frame-time measurements,
//! so what the tests see is what the panel shows.
//!
//! Why our own platform and not Slint's linuxkms backend: that backend pulls in libinput and,
//! next to the wgpu integration, forces Skia (whose build downloads binaries); ours needs
//! neither, and touch comes from the project's own evdev reader (the kiosk crate's touch).
//!
//! Never: reads input itself; callers dispatch events into [`KioskWindow::dispatch`].

use super::KioskError;
use slint::platform::software_renderer::{MinimalSoftwareWindow, RepaintBufferType, TargetPixel};
use slint::platform::{Platform, WindowAdapter, WindowEvent};
use slint::{PhysicalSize, PlatformError};
use std::rc::Rc;
use std::time::Duration;

/// Where Slint's timers and animations get the time from: the app's clock, so its own
/// accounting (the idle timeout) runs on the same time.
pub use crate::app::clock::Clock;

struct KioskPlatform {
    window: Rc<MinimalSoftwareWindow>,
    clock: Clock,
}

impl Platform for KioskPlatform {
    fn create_window_adapter(&self) -> Result<Rc<dyn WindowAdapter>, PlatformError> {
        Ok(self.window.clone())
    }

    fn duration_since_start(&self) -> Duration {
        self.clock.now()
    }
}

/// The one window of the kiosk platform and the pixels it was last drawn into.
pub struct KioskWindow {
    pub window: Rc<MinimalSoftwareWindow>,
    pub clock: Clock,
    size: [u32; 2],
}

impl KioskWindow {
    /// Installs the kiosk platform for this process (once: Slint allows one platform) with a
    /// window of `size` physical pixels.
    pub fn install(size: [u32; 2], clock: Clock) -> Result<KioskWindow, KioskError> {
        if size[0] == 0 || size[1] == 0 {
            return Err(KioskError::WindowSize { width: size[0], height: size[1] });
        }
        // Every frame repaints the whole buffer: screenshots and DRM buffers never hold stale
        // regions, and a full repaint of a 1920x1080 UI takes milliseconds.
        let window = MinimalSoftwareWindow::new(RepaintBufferType::NewBuffer);
        slint::platform::set_platform(Box::new(KioskPlatform { window: window.clone(), clock: clock.clone() }))
            .map_err(|error| KioskError::Platform { reason: error.to_string() })?;
        window.set_size(PhysicalSize::new(size[0], size[1]));
        Ok(KioskWindow { window, clock, size })
    }

    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    pub fn dispatch(&self, event: WindowEvent) {
        self.window.window().dispatch_event(event);
    }

    /// Runs due timers and animations (the app's poll timer among them).
    pub fn update_timers(&self) {
        slint::platform::update_timers_and_animations();
    }

    /// Draws the UI into `buffer` (`stride` pixels per row) if anything changed; true if drawn.
    pub fn draw_if_needed<P: TargetPixel>(&self, buffer: &mut [P], stride: usize) -> bool {
        self.window.draw_if_needed(|renderer| {
            renderer.render(buffer, stride);
        })
    }

    /// Forces the next [`draw_if_needed`](Self::draw_if_needed) to draw.
    pub fn request_redraw(&self) {
        self.window.request_redraw();
    }

    /// True while an animation runs (the loop should draw again soon).
    pub fn animating(&self) -> bool {
        self.window.has_active_animations()
    }

    /// How long until Slint's next timer is due (None: no timer).
    pub fn until_next_timer(&self) -> Option<Duration> {
        slint::platform::duration_until_next_timer_update()
    }
}

/// A pixel in the XRGB8888 layout of DRM dumb buffers.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Xrgb8888(pub u32);

impl TargetPixel for Xrgb8888 {
    fn blend(&mut self, color: slint::platform::software_renderer::PremultipliedRgbaColor) {
        let alpha = 255 - color.alpha as u32;
        let channel = |shift: u32, value: u8| {
            let old = (self.0 >> shift) & 0xff;
            ((value as u32 + old * alpha / 255).min(255)) << shift
        };
        self.0 = channel(16, color.red) | channel(8, color.green) | channel(0, color.blue);
    }

    fn from_rgb(red: u8, green: u8, blue: u8) -> Self {
        Xrgb8888(((red as u32) << 16) | ((green as u32) << 8) | blue as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use slint::platform::software_renderer::PremultipliedRgbaColor;

    #[test]
    fn xrgb_pixels_blend_premultiplied_colours() {
        let mut pixel = Xrgb8888::from_rgb(200, 100, 0);
        assert_eq!(pixel.0, 0x00c8_6400);
        // Half-transparent white, premultiplied: 128 per channel.
        pixel.blend(PremultipliedRgbaColor { red: 128, green: 128, blue: 128, alpha: 128 });
        assert_eq!(pixel.0 >> 16 & 0xff, 128 + 200 * 127 / 255);
        assert_eq!(pixel.0 & 0xff, 128);
        let mut opaque = Xrgb8888(0x0012_3456);
        opaque.blend(PremultipliedRgbaColor { red: 1, green: 2, blue: 3, alpha: 255 });
        assert_eq!(opaque.0, 0x0001_0203);
    }
}
