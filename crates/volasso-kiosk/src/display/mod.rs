//! The kiosk's screen: whole frames of XRGB8888 pixels shown on a DRM/KMS display, with no
//! window system, for the appliance image (deploy/README.md).
//!
//! Nouns: a *card* is a `/dev/dri/cardN` device; a *connector* is one of its outputs (HDMI-A-1,
//! Virtual-1) with a list of *modes*; a *CRTC* scans a *framebuffer* out to a connector. Entry
//! point: [`DrmDisplay::open`], then [`DrmDisplay::present`] once per frame: the caller draws
//! the whole back buffer (Slint's software renderer with `RepaintBufferType::SwappedBuffers`,
//! since the back buffer holds the frame from two presents ago) and it is page-flipped onto the
//! screen.
//!
//! Never: renders anything itself, reads input, or knows about Slint or the volume pipeline. It
//! uses dumb (CPU-mapped) buffers only; GPU rendering of the volume happens offscreen elsewhere.

mod drm;

pub use self::drm::{DisplayError, DrmDisplay, ModeCandidate, choose_mode};
