//! The kiosk around the app: the Slint platform that draws with the software renderer
//! (platform.rs), the routing of touches to the UI (router.rs), the appliance's loop that shows
//! it on a DRM display with touch from evdev (drm_loop.rs), and what they fail with (error.rs).
//! The replay harness that drives the same platform from scripts is the crate `volasso-replay`.

pub mod drm_loop;
pub mod error;
pub mod platform;
pub mod router;

pub use error::KioskError;
