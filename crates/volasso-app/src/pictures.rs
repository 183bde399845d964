//! The pictures the work screen shows on its slices: the grey slice through the display
//! window, the classification's colours over it (paper §3.5's colours, so slices and 3-D view
//! agree), and the voxels of the lassos drawn on this slice, highlighted the moment the finger
//! lifts (the feedback the paper's users missed). All three are drawn in the slice's image
//! coordinates and then arranged together by the panel's [`SliceLayout`] (the radiological
//! convention's flips and quarter turns), so colours always lie on the voxels they belong to.
//!
//! Never: touches the UI; pictures are plain [`RgbImage`]s.

use volasso_core::slices::{DisplayWindow, SliceGeometry, SliceLayout, slice_image};
use volasso_core::strokes::{Lasso, polygon_rows};
use volasso_core::transfer::{ClassStyle, DEFAULT_OVERLAY_ALPHA, HueTemplate, RgbImage, hsv_to_rgb, slice_overlay};
use volasso_core::volume::Volume;

/// How strongly lasso voxels are tinted: stronger than the classification overlay, so what
/// was just drawn stands out from what the classifier decided.
pub const LASSO_ALPHA: f32 = 0.6;

/// Why a slice picture cannot be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PictureError {
    /// The volume's file shrank under its memory map.
    #[error(transparent)]
    Volume(#[from] volasso_core::volume::VolumeError),
    #[error(transparent)]
    Slice(#[from] volasso_core::slices::SliceError),
    #[error(transparent)]
    Overlay(#[from] volasso_core::transfer::TransferError),
    #[error("slice {slice} along {axis} is outside the volume")]
    OutsideVolume { slice: usize, axis: volasso_core::slices::Axis },
    #[error("slice {slice} along {axis}: the picture does not hold its pixels")]
    Arrangement { slice: usize, axis: volasso_core::slices::Axis },
}

/// Lassos to highlight on a slice, each with its colour.
pub struct Highlight<'a> {
    pub lassos: &'a [Lasso],
    pub colour: [u8; 3],
}

/// The picture of `slice` along `layout.axis` as the screen shows it: grey, the
/// classification (labels and styles) if any, then the highlighted lassos that lie on this
/// slice, arranged by `layout`. An error when the volume's file shrank under its memory map
/// (reading it would crash the app).
pub fn slice_picture(
    volume: &Volume,
    layout: &SliceLayout,
    slice: usize,
    window: DisplayWindow,
    classification: Option<(&[u8], &[ClassStyle])>,
    highlights: &[Highlight],
    unsure: Option<&[bool]>,
) -> Result<RgbImage, PictureError> {
    volume.check_still_mapped()?;
    let axis = layout.axis;
    let mut picture = match classification {
        Some((labels, styles)) => slice_overlay(volume, labels, styles, axis, slice, window, DEFAULT_OVERLAY_ALPHA)?,
        None => {
            let grey = slice_image(volume, axis, slice, window)?;
            let pixels = grey.pixels.iter().flat_map(|&level| [level; 3]).collect();
            RgbImage { width: grey.width, height: grey.height, pixels }
        }
    };
    let Some(geometry) = SliceGeometry::new(volume.dims, axis, slice) else {
        return Err(PictureError::OutsideVolume { slice, axis });
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
    if let Some(unsure) = unsure.filter(|flags| flags.len() == picture.width * picture.height) {
        tint_unsure(&mut picture, unsure);
    }
    let (pixels, width, height) = layout
        .arrange_pixels(&picture.pixels, 3, picture.width, picture.height)
        .ok_or(PictureError::Arrangement { slice, axis })?;
    Ok(RgbImage { width, height, pixels })
}

/// How unsure voxels look: diagonal stripes of [`UNSURE_COLOUR`] every third voxel, the rest
/// lightened, over whatever class colour they have, so they stand out from every hue a
/// template can give a class.
pub const UNSURE_COLOUR: [u8; 3] = [255, 255, 255];

/// Marks the pixels flagged in `unsure` (one flag per pixel of `picture`, before arrangement).
fn tint_unsure(picture: &mut RgbImage, unsure: &[bool]) {
    let width = picture.width.max(1);
    for (pixel, _) in unsure.iter().enumerate().filter(|(_, flag)| **flag) {
        let (i, j) = (pixel % width, pixel / width);
        let alpha = if (i + j) % 3 == 0 { 0.85 } else { 0.35 };
        for (channel, &colour) in picture.pixels[3 * pixel..][..3].iter_mut().zip(&UNSURE_COLOUR) {
            *channel = (*channel as f32 * (1.0 - alpha) + colour as f32 * alpha).round() as u8;
        }
    }
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
    use crate::lasso::drawing::{FingerPath, PathMeaning};
    use volasso_core::phantom::demo_foot_with;
    use volasso_core::slices::Axis;
    use volasso_core::volume::PatientOrientation;

    #[test]
    fn lasso_voxels_on_the_slice_are_tinted_and_others_are_not() {
        let phantom = demo_foot_with([32, 24, 16], 3).unwrap();
        let volume = &phantom.volume;
        let window = DisplayWindow::automatic(volume);
        let layout = SliceLayout::new(None, Axis::Z);
        let plain = slice_picture(volume, &layout, 8, window, None, &[], None).unwrap();
        let lassos = [
            Lasso { axis: Axis::Z, slice: 8, points: vec![[1.5, 1.5], [5.5, 1.5], [5.5, 5.5], [1.5, 5.5]] },
            Lasso { axis: Axis::Z, slice: 9, points: vec![[10.0, 10.0], [20.0, 10.0], [20.0, 20.0]] },
        ];
        let tinted = slice_picture(
            volume,
            &layout,
            8,
            window,
            None,
            &[Highlight { lassos: &lassos, colour: [255, 0, 0] }],
            None,
        )
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

    /// The screen pixels of `picture` that are not grey.
    fn coloured(picture: &RgbImage) -> Vec<[usize; 2]> {
        (0..picture.width * picture.height)
            .filter(|&p| {
                let rgb = &picture.pixels[3 * p..][..3];
                rgb[0] != rgb[1] || rgb[1] != rgb[2]
            })
            .map(|p| [p % picture.width, p / picture.width])
            .collect()
    }

    #[test]
    fn lassos_and_classes_show_under_the_finger_on_flipped_and_turned_panels() {
        // A sagittally stored MRI (x anterior, y inferior, z left): every panel is turned or
        // flipped on screen.
        let dims = [12, 16, 20];
        let mut volume = Volume::from_f32(dims, [1.0; 3], &vec![0.5; 12 * 16 * 20], std::path::Path::new("t")).unwrap();
        volume.orientation = PatientOrientation::new([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]], None);
        let window = DisplayWindow::from_range(0.0, 1.0);
        let red = ClassStyle {
            hue_degrees: [0.0, 0.0],
            saturation: 1.0,
            value: 1.0,
            opacity: [1.0, 1.0],
            gradient_max: 1.0,
            emphasis: 1.0,
            visible: true,
        };
        // The finger goes round screen pixels 2..=5 across and 3..=8 down.
        let under_finger: Vec<[usize; 2]> = (3..=8).flat_map(|v| (2..=5).map(move |u| [u, v])).collect();
        for axis in Axis::ALL {
            let layout = SliceLayout::new(volume.orientation.as_ref(), axis);
            let [width, height] = layout.screen_size(dims).map(|side| side as f32);
            let at = |u: f32, v: f32| [(u + 0.5) / width, (v + 0.5) / height];
            let mut path = FingerPath::new([10.0 * width, 10.0 * height], at(1.5, 2.5), 0.0);
            for (k, point) in [at(5.5, 2.5), at(5.5, 8.5), at(1.5, 8.5), at(1.5, 2.5)].into_iter().enumerate() {
                path.add(point, 200.0 * (k + 1) as f64);
            }
            let PathMeaning::Lasso(lasso) = path.meaning(dims, &layout, 4) else { panic!("{axis}: not a lasso") };
            let highlighted = slice_picture(
                &volume,
                &layout,
                4,
                window,
                None,
                &[Highlight { lassos: std::slice::from_ref(&lasso), colour: [255, 0, 0] }],
                None,
            )
            .unwrap();
            assert_eq!([highlighted.width, highlighted.height], layout.screen_size(dims));
            assert_eq!(coloured(&highlighted), under_finger, "{axis}: lasso highlight");
            let mut labels = vec![0u8; volume.voxel_count()];
            for voxel in lasso.selected_voxels(dims) {
                labels[voxel] = 1;
            }
            let classified =
                slice_picture(&volume, &layout, 4, window, Some((&labels, std::slice::from_ref(&red))), &[], None)
                    .unwrap();
            assert_eq!(coloured(&classified), under_finger, "{axis}: class overlay");
        }
    }

    #[test]
    fn a_volume_file_truncated_while_open_gives_a_message_not_a_crash() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("cut_16x16x16_uint8.raw");
        std::fs::write(&path, vec![9u8; 4096]).unwrap();
        let volume = volasso_core::volume::open(&path, &volasso_core::volume::OpenOptions::default()).unwrap();
        assert!(volume.is_memory_mapped());
        let layout = SliceLayout::new(None, Axis::Z);
        let window = DisplayWindow::from_range(0.0, 255.0);
        assert!(slice_picture(&volume, &layout, 15, window, None, &[], None).is_ok());
        std::fs::OpenOptions::new().write(true).open(&path).unwrap().set_len(100).unwrap();
        let error = slice_picture(&volume, &layout, 15, window, None, &[], None).unwrap_err().to_string();
        assert!(error.contains(&path.display().to_string()), "{error}");
    }

    #[test]
    fn unsure_voxels_are_striped_on_screen_where_they_lie() {
        let phantom = demo_foot_with([32, 24, 16], 3).unwrap();
        let volume = &phantom.volume;
        let window = DisplayWindow::automatic(volume);
        let layout = SliceLayout::new(None, Axis::Z);
        let plain = slice_picture(volume, &layout, 8, window, None, &[], None).unwrap();
        let mut unsure = vec![false; 32 * 24];
        for pixel in [0, 5, 6, 7, 40] {
            unsure[pixel] = true;
        }
        let marked = slice_picture(volume, &layout, 8, window, None, &[], Some(&unsure)).unwrap();
        let changed: Vec<usize> = (0..plain.width * plain.height)
            .filter(|&p| plain.pixels[3 * p..][..3] != marked.pixels[3 * p..][..3])
            .collect();
        let brighter = |p: usize| marked.pixels[3 * p] > plain.pixels[3 * p];
        assert!(changed.iter().all(|p| unsure[*p] && brighter(*p)), "{changed:?}");
        assert!(changed.len() >= 4, "{changed:?}");
        let wrong_size = slice_picture(volume, &layout, 8, window, None, &[], Some(&[true; 3])).unwrap();
        assert_eq!(wrong_size.pixels, plain.pixels, "flags of another slice's size are ignored");
    }

    #[test]
    fn class_colours_differ_between_classes() {
        let template = HueTemplate::default_for(3);
        let colours: Vec<[u8; 3]> = (0..3).map(|k| class_colour(None, &template, k, 3)).collect();
        assert_ne!(colours[0], colours[1]);
        assert_ne!(colours[1], colours[2]);
    }
}
