//! Transfer functions from classes: harmonic hue templates and per-class colour and opacity
//! (paper §3.5, eq. 4-9; `harmony.md`).
//!
//! The output of this stage is a small table, one [`ClassStyle`] per class, from which any
//! voxel's RGBA follows given its class and gradient factor. The renderer evaluates the table
//! after interpolation (post-classification); [`ClassStyle::rgba`] evaluates it on the CPU for
//! the paper's pre-classified RGBA volume.
//!
//! Never: classifies, or touches the GPU.

pub mod style;

pub use style::{ClassStyle, hsv_to_rgb};
