//! The work screen's display windows (window/level, as in a CT viewer): the presets a finger
//! picks, and the two-finger drag on a slice that adjusts the window.
//!
//! Which presets: CT or not is [`looks_like_ct`] (the values reach air and dense tissue, so
//! they are Hounsfield units; a CT stored as unsigned values without its rescale is not
//! recognised and gets the percentile windows below). The volume does not carry DICOM's
//! Modality, so the value range is the only evidence, for DICOM series as for every other
//! format.
//! * CT: **Auto** ([`DisplayWindow::automatic`]: fat and soft tissue to dense bone), and the
//!   standard windows as width/level in HU: **Soft tissue** 400/40, **Lung** 1500/-600,
//!   **Bone** 2000/300, **Brain** 80/40.
//! * Anything else (MRI, 8-bit scans: no physical unit): windows from percentiles of the
//!   *foreground* (voxels at or above the background level, [`Volume::otsu_threshold`], so the
//!   air around the body does not set black): **Auto** the 1st to 99th percentile,
//!   **Contrast** the 5th to 95th, and **Full range** the smallest to the largest value.
//!
//! The drag ([`dragged`]): moving two fingers up by the slice's whole height lowers the level by
//! one window width (the picture gets brighter), down raises it; moving them right by the
//! slice's whole width widens the window four times (less contrast), left narrows it.
//!
//! Never: changes stored values. A window is for display only; the classifier reads the stored
//! values whatever window is shown.

use volasso_core::slices::{DisplayWindow, looks_like_ct};
use volasso_core::volume::{ValueRange, Volume};

/// A named window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowPreset {
    pub name: &'static str,
    pub window: DisplayWindow,
}

/// CT windows as (name, width, level) in Hounsfield units.
const CT_WINDOWS: [(&str, f64, f64); 4] =
    [("Soft tissue", 400.0, 40.0), ("Lung", 1500.0, -600.0), ("Bone", 2000.0, 300.0), ("Brain", 80.0, 40.0)];

/// Percentiles of the foreground for the windows of other scans: (name, low, high).
const PERCENTILE_WINDOWS: [(&str, f64, f64); 2] = [("Auto", 0.01, 0.99), ("Contrast", 0.05, 0.95)];

/// The name of a window set by dragging.
pub const CUSTOM: &str = "Custom";

/// A vertical drag over the whole slice moves the level by this many window widths.
const LEVEL_WIDTHS_PER_HEIGHT: f64 = 1.0;
/// A horizontal drag over the whole slice multiplies the width by this.
const WIDTH_FACTOR_PER_WIDTH: f64 = 4.0;

/// The windows offered for one volume, the first being the one it opens with.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowChoices {
    pub presets: Vec<WindowPreset>,
    pub is_ct: bool,
}

impl WindowChoices {
    /// The presets of `volume` (module doc). One pass over the volume (two for CT: Auto's
    /// percentiles); call it off the UI thread.
    pub fn for_volume(volume: &Volume) -> WindowChoices {
        let range = volume.value_range();
        let full = DisplayWindow::from_range(range.min, range.max);
        if looks_like_ct(volume) {
            let mut presets = vec![WindowPreset { name: "Auto", window: DisplayWindow::automatic(volume) }];
            presets.extend(
                CT_WINDOWS
                    .map(|(name, width, level)| WindowPreset { name, window: DisplayWindow { center: level, width } }),
            );
            return WindowChoices { presets, is_ct: true };
        }
        let background = volume.otsu_threshold();
        let mut presets: Vec<WindowPreset> = PERCENTILE_WINDOWS
            .iter()
            .map(|&(name, low, high)| WindowPreset {
                name,
                window: DisplayWindow::between_percentiles(volume, background, low, high)
                    .or_else(|| DisplayWindow::between_percentiles(volume, range.min, low, high))
                    .unwrap_or(full),
            })
            .collect();
        presets.push(WindowPreset { name: "Full range", window: full });
        WindowChoices { presets, is_ct: false }
    }

    /// The window a volume opens with.
    pub fn initial(&self) -> WindowPreset {
        self.presets
            .first()
            .copied()
            .unwrap_or(WindowPreset { name: "Auto", window: DisplayWindow::from_range(0.0, 1.0) })
    }

    pub fn find(&self, name: &str) -> Option<WindowPreset> {
        self.presets.iter().find(|preset| preset.name == name).copied()
    }

    pub fn names(&self) -> Vec<&'static str> {
        self.presets.iter().map(|preset| preset.name).collect()
    }
}

/// `window` after a two-finger drag of `fraction` of the slice's width and height (x right,
/// y down), kept within sensible bounds for values in `range` (module doc).
pub fn dragged(window: DisplayWindow, fraction: [f32; 2], range: ValueRange) -> DisplayWindow {
    if !fraction.iter().all(|f| f.is_finite()) {
        return window;
    }
    let span = (range.max - range.min).abs().max(1e-6);
    let width = (window.width * WIDTH_FACTOR_PER_WIDTH.powf(fraction[0] as f64)).clamp(span * 1e-3, span * 4.0);
    let center = (window.center + fraction[1] as f64 * LEVEL_WIDTHS_PER_HEIGHT * width)
        .clamp(range.min - width / 2.0, range.max + width / 2.0);
    DisplayWindow { center, width }
}

/// "Brain W80 L40": a window for the status line and replay's `expect window`.
pub fn describe(name: &str, window: DisplayWindow) -> String {
    format!("{name} W{} L{}", round_for_display(window.width), round_for_display(window.center))
}

fn round_for_display(value: f64) -> String {
    if value.abs() >= 10.0 { format!("{:.0}", value) } else { format!("{:.2}", value) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn volume_of(values: Vec<i16>) -> Volume {
        let values: Vec<f32> = values.into_iter().map(f32::from).collect();
        Volume::from_f32([10, 10, values.len() / 100], [1.0; 3], &values, Path::new("t")).unwrap()
    }

    #[test]
    fn ct_gets_the_standard_windows_and_auto_first() {
        // Air, soft tissue and bone in HU.
        let values = (0..1000).map(|i| [-1000i16, 40, 1200][i % 3]).collect();
        let choices = WindowChoices::for_volume(&volume_of(values));
        assert!(choices.is_ct);
        assert_eq!(choices.names(), ["Auto", "Soft tissue", "Lung", "Bone", "Brain"]);
        assert_eq!(choices.initial().name, "Auto");
        let brain = choices.find("Brain").unwrap().window;
        assert_eq!((brain.width, brain.center), (80.0, 40.0));
        let lung = choices.find("Lung").unwrap().window;
        assert_eq!((lung.width, lung.center), (1500.0, -600.0));
        // Each window's level is mid-grey in it, and bone is white or nearly in every window.
        assert_eq!(brain.grey(40.0), 128);
        assert_eq!(lung.grey(-600.0), 128);
        assert!(choices.presets.iter().all(|p| p.window.grey(1200.0) >= 200), "{choices:?}");
    }

    #[test]
    fn mri_windows_come_from_the_foregrounds_percentiles() {
        // 70 % background at 0..=9, the foreground spread evenly over 1000..=1299.
        let values: Vec<i16> =
            (0..1000).map(|i| if i % 10 < 7 { (i % 10) as i16 } else { 1000 + ((i * 7) % 300) as i16 }).collect();
        let volume = volume_of(values);
        let choices = WindowChoices::for_volume(&volume);
        assert!(!choices.is_ct);
        assert_eq!(choices.names(), ["Auto", "Contrast", "Full range"]);
        let auto = choices.initial().window;
        let (black, white) = (auto.center - auto.width / 2.0, auto.center + auto.width / 2.0);
        // The background does not set black: black is at the foreground's bottom.
        assert!(volume.otsu_threshold() < 1000.0);
        assert!((1000.0..=1015.0).contains(&black), "black {black}");
        assert!((1285.0..=1300.0).contains(&white), "white {white}");
        let contrast = choices.find("Contrast").unwrap().window;
        assert!(contrast.width < auto.width);
        let full = choices.find("Full range").unwrap().window;
        assert_eq!(full.center - full.width / 2.0, 0.0);
    }

    #[test]
    fn dragging_moves_the_level_and_scales_the_width_within_bounds() {
        let range = ValueRange { min: -1024.0, max: 3000.0, non_finite_voxels: 0 };
        let window = DisplayWindow { center: 40.0, width: 400.0 };
        let up = dragged(window, [0.0, -0.5], range);
        assert_eq!((up.center, up.width), (-160.0, 400.0));
        assert!(up.grey(40.0) > window.grey(40.0), "dragging up brightens");
        let right = dragged(window, [0.5, 0.0], range);
        assert!((right.width - 800.0).abs() < 1e-9 && right.center == 40.0);
        let extreme = dragged(window, [100.0, 100.0], range);
        assert!(extreme.width <= 4.0 * 4024.0 && extreme.center <= 3000.0 + extreme.width / 2.0);
        assert_eq!(dragged(window, [f32::NAN, 0.0], range), window);
        assert_eq!(describe("Brain", DisplayWindow { center: 40.0, width: 80.0 }), "Brain W80 L40");
    }
}
