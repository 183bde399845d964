//! The Rust side of `ui/*.slint`, generated at build time (build.rs): `AppWindow`, the
//! `Session` global and the structs it shows.
#![allow(clippy::all, clippy::pedantic, missing_docs, unused_qualifications)]

slint::include_modules!();
