//! Slice overlays: class colours over the grey slice the user lassos on, so the
//! classification can be checked slice by slice, exportable as PNG.
//!
//! Each labelled pixel takes its class's colour at the voxel's own gradient factor (the RGB of
//! [`ClassStyle::rgba`], what the RGBA volume holds), blended over the grey level at `alpha`;
//! pixels on a class boundary (a 4-neighbour in the slice has another label) are drawn at full
//! colour so that the outlines stay crisp. Background, hidden classes and classes with
//! emphasis 0 leave the grey untouched. Image axes are those of [`slice_image`]
//! (`interfaces.md`: z -> (x, y), y -> (x, z), x -> (y, z)).
//!
//! Never: changes styles or labels, or draws lassos.

use super::harmony::check_labels;
use super::{ClassStyle, TransferError};
use crate::atomic_file::write_atomically;
use crate::features::features_at;
use crate::slices::{Axis, DisplayWindow, SliceGeometry, slice_image};
use crate::volume::Volume;
use std::io::Write;
use std::path::Path;

/// Weight of the class colour over the grey level inside a class: enough to tell the classes
/// apart at a glance while the anatomy under them stays readable.
pub const DEFAULT_OVERLAY_ALPHA: f32 = 0.45;

/// An 8-bit RGB image, row-major (`pixels[3 * (j * width + i)..][..3]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// `3 × width × height` bytes: red, green, blue of each pixel, row by row.
    pub pixels: Vec<u8>,
}

/// Slice `slice` along `axis` in grey through `window`, with class colours blended at `alpha`
/// (0..=1) and class boundaries at full colour.
pub fn slice_overlay(
    volume: &Volume,
    labels: &[u8],
    styles: &[ClassStyle],
    axis: Axis,
    slice: usize,
    window: DisplayWindow,
    alpha: f32,
) -> Result<RgbImage, TransferError> {
    check_labels(volume, labels, styles.len())?;
    let grey = slice_image(volume, axis, slice, window)?;
    // slice_image has checked the slice.
    let Some(geometry) = SliceGeometry::new(volume.dims, axis, slice) else {
        return Err(TransferError::Slice(crate::slices::SliceError::SliceOutOfRange {
            axis,
            slice,
            slice_count: volume.dims[axis.position()],
        }));
    };
    let alpha = alpha.clamp(0.0, 1.0);
    let (width, height) = (geometry.width, geometry.height);
    let label_at = |i: usize, j: usize| labels[geometry.voxel_index(i, j)];
    let mut pixels = Vec::with_capacity(width * height * 3);
    for j in 0..height {
        for i in 0..width {
            let level = grey.pixels[j * width + i] as f32 / 255.0;
            let label = label_at(i, j);
            let style = (label > 0).then(|| &styles[label as usize - 1]).filter(|s| s.visible && s.emphasis > 0.0);
            let Some(style) = style else {
                pixels.extend([grey.pixels[j * width + i]; 3]);
                continue;
            };
            let on_boundary = (i > 0 && label_at(i - 1, j) != label)
                || (i + 1 < width && label_at(i + 1, j) != label)
                || (j > 0 && label_at(i, j - 1) != label)
                || (j + 1 < height && label_at(i, j + 1) != label);
            let weight = if on_boundary { 1.0 } else { alpha };
            let gradient = features_at(volume, geometry.voxel_index(i, j))[1];
            let colour = style.rgba(if gradient.is_finite() { gradient } else { 0.0 });
            for channel in &colour[..3] {
                let blended = level * (1.0 - weight) + channel * weight;
                pixels.push((blended * 255.0 + 0.5).clamp(0.0, 255.0) as u8);
            }
        }
    }
    Ok(RgbImage { width, height, pixels })
}

/// Writes `image` as an 8-bit RGB PNG, atomically.
pub fn write_png(path: &Path, image: &RgbImage) -> Result<(), TransferError> {
    use image::ImageEncoder;
    let mut encoded = Vec::new();
    image::codecs::png::PngEncoder::new(&mut encoded)
        .write_image(&image.pixels, image.width as u32, image.height as u32, image::ExtendedColorType::Rgb8)
        .map_err(|source| TransferError::Png { source, path: path.to_path_buf() })?;
    write_atomically(path, |file| file.write_all(&encoded))
        .map_err(|source| TransferError::Io { source, path: path.to_path_buf() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::demo_foot_with;
    use crate::transfer::{HueTemplate, class_styles};

    #[test]
    fn classes_are_tinted_and_background_stays_grey() {
        let phantom = demo_foot_with([40, 28, 20], 5).unwrap();
        let (volume, labels) = (phantom.volume, phantom.truth);
        let mut styles = class_styles(&volume, &labels, 3, &HueTemplate::default_for(3)).unwrap();
        let window = DisplayWindow::automatic(&volume);
        for axis in Axis::ALL {
            let slice = volume.dims[axis.position()] / 2;
            let overlay = slice_overlay(&volume, &labels, &styles, axis, slice, window, 0.5).unwrap();
            let grey = slice_image(&volume, axis, slice, window).unwrap();
            assert_eq!((overlay.width, overlay.height), (grey.width, grey.height));
            let geometry = SliceGeometry::new(volume.dims, axis, slice).unwrap();
            let mut tinted = 0;
            for j in 0..grey.height {
                for i in 0..grey.width {
                    let rgb = &overlay.pixels[3 * (j * grey.width + i)..][..3];
                    if labels[geometry.voxel_index(i, j)] == 0 {
                        assert_eq!(rgb, [grey.pixels[j * grey.width + i]; 3]);
                    } else if rgb[0] != rgb[1] || rgb[1] != rgb[2] {
                        tinted += 1;
                    }
                }
            }
            assert!(tinted > 0, "{axis}");
        }
        styles.iter_mut().for_each(|s| s.visible = false);
        let hidden = slice_overlay(&volume, &labels, &styles, Axis::Z, 10, window, 0.5).unwrap();
        assert!(hidden.pixels.chunks_exact(3).all(|p| p[0] == p[1] && p[1] == p[2]));
        assert!(slice_overlay(&volume, &labels, &styles, Axis::Z, 20, window, 0.5).is_err());
    }

    #[test]
    fn png_files_decode_to_the_same_pixels() {
        let image = RgbImage { width: 3, height: 2, pixels: (0..18).map(|v| v * 14).collect() };
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("overlay.png");
        write_png(&path, &image).unwrap();
        let decoded = image::open(&path).unwrap().to_rgb8();
        assert_eq!((decoded.width(), decoded.height()), (3, 2));
        assert_eq!(decoded.into_raw(), image.pixels);
    }
}
