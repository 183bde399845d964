//! The kiosk around the app: the Slint platform that draws with the software renderer
//! (platform.rs), the routing of touches to the UI (router.rs), the replay harness that drives
//! the real UI from scripts (harness.rs, replay.rs) and checks its controls fit a finger
//! (layout.rs), the appliance's loop that shows it on a
//! DRM display with touch from evdev (drm_loop.rs), the panel's pixel density that sizes touch
//! targets (dpi.rs), the memory one volume may take in the
//! kiosk (memory.rs), and what all of them fail with (error.rs).

pub mod drm_loop;
pub mod error;
pub mod harness;
pub mod layout;
pub mod platform;
pub mod replay;
pub mod router;

pub use error::KioskError;
