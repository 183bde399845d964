//! The Rust side of `ui/*.slint` (the volasso-ui crate): `AppWindow`, the `Session` global
//! and the structs it shows.

pub use volasso_ui::*;
