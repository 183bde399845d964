//! The panel's pixel density, from which the UI sizes its touch targets and text (`Theme.dpi`
//! in ui/theme.slint): a touch target is [`TOUCH_TARGET_MM`] at least on any panel. The density
//! is `--dpi` when given, else the DRM connector's physical size (EDID) when it is believable,
//! else [`DEFAULT_DPI`].
//!
//! Why a believability check: EDIDs lie. Projectors and some TVs report 0 mm, others their
//! aspect ratio in centimetres (16 x 9 "mm"), and a few the size of the desk they might sit on.
//! A density outside [`DPI_RANGE`] is taken as unknown.
//!
//! Never: reads the EDID itself (the kiosk crate's display module does), or scales anything but the UI.

/// The smallest touch target, in millimetres (the common guidance for touch kiosks is 9-10 mm:
/// a fingertip's contact patch, with room for a hurried or gloved finger).
pub const TOUCH_TARGET_MM: f32 = 9.0;

/// The density assumed when nothing says better: a 10.1-inch 1280x800 panel, the common
/// bedside and table panel (149.5 dpi), at which the UI's reference sizes were drawn.
pub const DEFAULT_DPI: f32 = 150.0;

/// Densities taken as believable, for `--dpi` and for an EDID's size.
pub const DPI_RANGE: std::ops::RangeInclusive<f32> = 40.0..=600.0;

/// Millimetres per inch.
const MM_PER_INCH: f32 = 25.4;

/// The density of a panel of `pixels` whose picture measures `millimetres`, when believable:
/// both sides known, and the two axes' densities within 25 % of each other (square pixels; a
/// size given in centimetres or as an aspect ratio fails this or [`DPI_RANGE`]).
pub fn from_physical_size(pixels: [u32; 2], millimetres: [u32; 2]) -> Option<f32> {
    if pixels.contains(&0) || millimetres.contains(&0) {
        return None;
    }
    let per_axis = [0, 1].map(|axis| pixels[axis] as f32 / (millimetres[axis] as f32 / MM_PER_INCH));
    let (low, high) = (per_axis[0].min(per_axis[1]), per_axis[0].max(per_axis[1]));
    if high > low * 1.25 {
        return None;
    }
    let dpi = (per_axis[0] + per_axis[1]) / 2.0;
    DPI_RANGE.contains(&dpi).then_some(dpi)
}

/// The density to use: `chosen` (`--dpi`), else the panel's own, else [`DEFAULT_DPI`].
pub fn resolve(chosen: Option<f32>, panel: Option<f32>) -> f32 {
    let believable = |dpi: &f32| DPI_RANGE.contains(dpi);
    chosen.filter(believable).or(panel.filter(believable)).unwrap_or(DEFAULT_DPI)
}

/// `millimetres` in pixels at `dpi`.
pub fn mm_to_pixels(millimetres: f32, dpi: f32) -> f32 {
    millimetres / MM_PER_INCH * dpi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panels_report_believable_densities() {
        // A 10.1-inch 1280x800 panel: 217 x 136 mm.
        let dpi = from_physical_size([1280, 800], [217, 136]).unwrap();
        assert!((149.0..=150.5).contains(&dpi), "{dpi}");
        // A 7-inch 1024x600 panel: 154 x 86 mm, about 170 dpi.
        let dpi = from_physical_size([1024, 600], [154, 86]).unwrap();
        assert!((165.0..=180.0).contains(&dpi), "{dpi}");
        // A 24-inch 1080p monitor: 531 x 299 mm, about 92 dpi.
        let dpi = from_physical_size([1920, 1080], [531, 299]).unwrap();
        assert!((90.0..=93.0).contains(&dpi), "{dpi}");
    }

    #[test]
    fn lying_edids_are_unknown() {
        assert_eq!(from_physical_size([1920, 1080], [0, 0]), None, "a projector");
        assert_eq!(from_physical_size([1920, 1080], [16, 9]), None, "the aspect ratio in cm");
        assert!(from_physical_size([1920, 1080], [160, 90]).is_some(), "a 7-inch 1080p panel");
        assert_eq!(from_physical_size([1920, 1080], [531, 100]), None, "pixels far from square");
        assert_eq!(from_physical_size([1920, 1080], [5000, 2800]), None, "a wall");
        assert_eq!(from_physical_size([0, 1080], [531, 299]), None);
    }

    #[test]
    fn the_chosen_density_wins_then_the_panels_then_the_default() {
        assert_eq!(resolve(Some(200.0), Some(92.0)), 200.0);
        assert_eq!(resolve(None, Some(92.0)), 92.0);
        assert_eq!(resolve(None, None), DEFAULT_DPI);
        assert_eq!(resolve(Some(f32::NAN), Some(92.0)), 92.0);
        assert_eq!(resolve(Some(f32::NAN), None), DEFAULT_DPI);
        // 9 mm at the default density is 53 px.
        assert!((mm_to_pixels(TOUCH_TARGET_MM, DEFAULT_DPI) - 53.15).abs() < 0.01);
    }
}
