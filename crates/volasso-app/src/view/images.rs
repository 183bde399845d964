//! Pictures as Slint shows them: the 3-D view's and the turntable's (RGBA), the slices' and
//! the cards' thumbnails (RGB).
//!
//! Never: draws; it only copies pixels into Slint's buffers.

use volasso_core::transfer::RgbImage;

/// A rendered picture (the 3-D view's, a turntable's) as Slint shows it.
pub(crate) fn rgba_to_slint_image(image: &image::RgbaImage) -> slint::Image {
    let buffer =
        slint::SharedPixelBuffer::<slint::Rgba8Pixel>::clone_from_slice(image.as_raw(), image.width(), image.height());
    slint::Image::from_rgba8(buffer)
}

pub(crate) fn to_slint_image(image: &RgbImage) -> slint::Image {
    if image.width == 0 || image.height == 0 {
        return slint::Image::default();
    }
    let buffer = slint::SharedPixelBuffer::<slint::Rgb8Pixel>::clone_from_slice(
        &image.pixels,
        image.width as u32,
        image.height as u32,
    );
    slint::Image::from_rgb8(buffer)
}
