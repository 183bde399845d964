//! The pictures the work screen shows on its slices: the grey slice through the display
//! window, the classification's colours over it (paper §3.5's colours, so slices and 3-D view
//! agree), and the voxels of the lassos drawn on this slice, highlighted the moment the finger
//! lifts (the feedback the paper's users missed).
//!
//! Never: touches the UI; pictures are plain [`RgbImage`]s.

use crate::slices::{Axis, DisplayWindow, SliceGeometry, slice_image};
use crate::strokes::{Lasso, polygon_rows};
use crate::transfer::{ClassStyle, DEFAULT_OVERLAY_ALPHA, HueTemplate, RgbImage, hsv_to_rgb, slice_overlay};
use crate::volume::Volume;

/// How strongly lasso voxels are tinted: stronger than the classification overlay, so what
/// was just drawn stands out from what the classifier decided.
pub const LASSO_ALPHA: f32 = 0.6;

/// Lassos to highlight on a slice, each with its colour.
pub struct Highlight<'a> {
    pub lassos: &'a [Lasso],
    pub colour: [u8; 3],
}

/// The picture of `slice` along `axis`: grey, the classification (labels and styles) if
/// any, then the highlighted lassos that lie on this slice.
pub fn slice_picture(
    volume: &Volume,
    axis: Axis,
    slice: usize,
    window: DisplayWindow,
    classification: Option<(&[u8], &[ClassStyle])>,
    highlights: &[Highlight],
) -> Result<RgbImage, String> {
    let mut picture = match classification {
        Some((labels, styles)) => slice_overlay(volume, labels, styles, axis, slice, window, DEFAULT_OVERLAY_ALPHA)
            .map_err(|e| e.to_string())?,
        None => {
            let grey = slice_image(volume, axis, slice, window).map_err(|e| e.to_string())?;
            let pixels = grey.pixels.iter().flat_map(|&level| [level; 3]).collect();
            RgbImage { width: grey.width, height: grey.height, pixels }
        }
    };
    let Some(geometry) = SliceGeometry::new(volume.dims, axis, slice) else {
        return Ok(picture);
    };
    for highlight in highlights {
        for lasso in highlight.lassos.iter().filter(|lasso| lasso.axis == axis && lasso.slice == slice) {
            polygon_rows(&lasso.points, geometry.width, geometry.height, |j, start, end| {
                for i in start..end {
                    let pixel = &mut picture.pixels[3 * (j * picture.width + i)..][..3];
                    for (channel, &colour) in pixel.iter_mut().zip(&highlight.colour) {
                        *channel = (*channel as f32 * (1.0 - LASSO_ALPHA) + colour as f32 * LASSO_ALPHA).round() as u8;
                    }
                }
            });
        }
    }
    Ok(picture)
}

/// The colour a class is shown with in the class bar: its style's mid hue once classified,
/// the template's hue for it before.
pub fn class_colour(style: Option<&ClassStyle>, template: &HueTemplate, index: usize, class_count: usize) -> [u8; 3] {
    let rgb = match style {
        Some(style) => hsv_to_rgb(0.5 * (style.hue_degrees[0] + style.hue_degrees[1]), style.saturation, style.value),
        None => {
            let hue = template.centre_hues(class_count.max(1)).get(index).copied().unwrap_or(0.0);
            hsv_to_rgb(hue, 0.75, 0.95)
        }
    };
    rgb.map(|channel| (channel.clamp(0.0, 1.0) * 255.0).round() as u8)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::demo_foot_with;

    #[test]
    fn lasso_voxels_on_the_slice_are_tinted_and_others_are_not() {
        let phantom = demo_foot_with([32, 24, 16], 3).unwrap();
        let volume = &phantom.volume;
        let window = DisplayWindow::automatic(volume);
        let plain = slice_picture(volume, Axis::Z, 8, window, None, &[]).unwrap();
        let lassos = [
            Lasso { axis: Axis::Z, slice: 8, points: vec![[1.5, 1.5], [5.5, 1.5], [5.5, 5.5], [1.5, 5.5]] },
            Lasso { axis: Axis::Z, slice: 9, points: vec![[10.0, 10.0], [20.0, 10.0], [20.0, 20.0]] },
        ];
        let tinted =
            slice_picture(volume, Axis::Z, 8, window, None, &[Highlight { lassos: &lassos, colour: [255, 0, 0] }])
                .unwrap();
        let changed: Vec<usize> = (0..plain.width * plain.height)
            .filter(|&p| plain.pixels[3 * p..][..3] != tinted.pixels[3 * p..][..3])
            .collect();
        // Centres 2..=5 in x and y: 4 x 4 voxels, and nothing from the lasso on slice 9.
        assert_eq!(changed.len(), 16);
        assert!(changed.iter().all(|&p| (2..=5).contains(&(p % 32)) && (2..=5).contains(&(p / 32))));
        let pixel = &tinted.pixels[3 * (3 * 32 + 3)..][..3];
        assert!(pixel[0] > pixel[1] && pixel[0] > pixel[2], "{pixel:?}");
    }

    #[test]
    fn class_colours_differ_between_classes() {
        let template = HueTemplate::default_for(3);
        let colours: Vec<[u8; 3]> = (0..3).map(|k| class_colour(None, &template, k, 3)).collect();
        assert_ne!(colours[0], colours[1]);
        assert_ne!(colours[1], colours[2]);
    }
}
