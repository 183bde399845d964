//! Harmonic hue templates (paper §3.5, Fig. 3; Cohen-Or et al. 2006; `docs/colour.md`) and the
//! per-class hue ranges of eq. 4 laid out along them.
//!
//! A [`HueTemplate`] is a [`TemplateType`] (one or two sectors of the hue wheel) turned by a
//! rotation in degrees. Its sectors are walked as one concatenated interval of length `A` (sector
//! 1 from its low edge, then sector 2); class `k` of `Z` (0-based) has its range centre at arc
//! position `A (k + 0.5) / Z`, mapped back onto the wheel. A range is the interval of the wheel
//! of width [`HueTemplate::range_width_degrees`] centred on that hue: 18 degrees (the paper's 5 %
//! of the wheel) while the classes fit, else shrunk to 0.9 `A / Z`, so neighbours on one sector
//! never overlap or touch and never share a centre. Ranges on different sectors cannot meet
//! either: every gap between two sectors is at least 41.4 degrees, more than one range. Keeping
//! a range one interval of the wheel (rather than folding it at a sector's edge) is what lets
//! eq. 4 interpolate linearly; the price is that a range whose centre lies within 9 degrees of a
//! sector's edge reaches up to 9 degrees past it.
//!
//! [`HueTemplate::default_for`] picks a template and rotation from the number of classes (the
//! rule and its reasons are on that function); the caller may replace either.
//!
//! Never: looks at voxels, or decides saturation, value or opacity.

use serde::{Deserialize, Serialize};

/// Width of a class's hue range while the classes fit: 5 % of the wheel (paper §3.5).
pub const RANGE_WIDTH_DEGREES: f32 = 18.0;

/// The fraction of the centre spacing a shrunk range keeps, so neighbours keep a gap.
const SHRUNK_FRACTION: f32 = 0.9;

/// The template types of Cohen-Or et al. (the paper uses V, L, T and X). The grey-only type N
/// has no hues and is left out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemplateType {
    /// One narrow sector (18 degrees); named lowercase `i` in the literature and in files.
    #[serde(rename = "i")]
    NarrowI,
    /// One sector of 93.6 degrees.
    V,
    /// A narrow sector (18 degrees) and a wide one (79.2 degrees) 90 degrees away.
    L,
    /// Two narrow sectors (18 degrees) opposite each other.
    I,
    /// One half of the hue wheel (180 degrees).
    T,
    /// A wide sector (93.6 degrees) and a narrow one (18 degrees) opposite it.
    Y,
    /// Two wide sectors (93.6 degrees) opposite each other.
    X,
}

/// One sector of a template: its centre's offset from the template's rotation, and its width.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sector {
    /// Angle of the sector's centre from the template's rotation, in degrees.
    pub centre_offset_degrees: f32,
    /// The sector's angular width in degrees.
    pub width_degrees: f32,
}

impl TemplateType {
    /// Every template type, narrow `i` first.
    pub const ALL: [TemplateType; 7] = [
        TemplateType::NarrowI,
        TemplateType::V,
        TemplateType::L,
        TemplateType::I,
        TemplateType::T,
        TemplateType::Y,
        TemplateType::X,
    ];

    /// The template's name as in the literature: "i", "V", "L", "I", "T", "Y", "X".
    pub fn name(self) -> &'static str {
        match self {
            TemplateType::NarrowI => "i",
            TemplateType::V => "V",
            TemplateType::L => "L",
            TemplateType::I => "I",
            TemplateType::T => "T",
            TemplateType::Y => "Y",
            TemplateType::X => "X",
        }
    }

    /// Parses a name from [`name`](Self::name) (case matters: "i" and "I" differ).
    pub fn from_name(name: &str) -> Option<TemplateType> {
        TemplateType::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The sectors in walking order (widths and centre distances from `docs/colour.md`).
    pub fn sectors(self) -> &'static [Sector] {
        const fn sector(centre_offset_degrees: f32, width_degrees: f32) -> Sector {
            Sector { centre_offset_degrees, width_degrees }
        }
        const NARROW_I: [Sector; 1] = [sector(0.0, 18.0)];
        const V: [Sector; 1] = [sector(0.0, 93.6)];
        const L: [Sector; 2] = [sector(0.0, 18.0), sector(90.0, 79.2)];
        const I: [Sector; 2] = [sector(0.0, 18.0), sector(180.0, 18.0)];
        const T: [Sector; 1] = [sector(0.0, 180.0)];
        const Y: [Sector; 2] = [sector(0.0, 93.6), sector(180.0, 18.0)];
        const X: [Sector; 2] = [sector(0.0, 93.6), sector(180.0, 93.6)];
        match self {
            TemplateType::NarrowI => &NARROW_I,
            TemplateType::V => &V,
            TemplateType::L => &L,
            TemplateType::I => &I,
            TemplateType::T => &T,
            TemplateType::Y => &Y,
            TemplateType::X => &X,
        }
    }

    /// `A`: the total length of the sectors' arcs in degrees.
    pub fn arc_length_degrees(self) -> f32 {
        self.sectors().iter().map(|s| s.width_degrees).sum()
    }
}

/// A template turned by `rotation_degrees` (any real; only its value modulo 360 matters).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HueTemplate {
    /// The template's sectors.
    pub template: TemplateType,
    /// Hue angle in degrees the template is turned by.
    pub rotation_degrees: f32,
}

impl HueTemplate {
    /// The template `template` turned by `rotation_degrees`.
    pub fn new(template: TemplateType, rotation_degrees: f32) -> HueTemplate {
        HueTemplate { template, rotation_degrees }
    }

    /// The default for `class_count` classes:
    /// * 1 class: V turned to 200 degrees (azure), a hue that stays clear and light on a dark
    ///   background even at the lower values of eq. 8;
    /// * 2 classes: I (complementary) at 10 degrees: red against cyan, the largest contrast two
    ///   hues can have;
    /// * 3 or 4 classes: T at 280 degrees: the half wheel from 190 (azure) through blue, violet
    ///   and magenta to 10 (red), 60 or 45 degrees between classes, and no yellow, olive or
    ///   orange, which the values of eq. 8 (down to about 0.53) turn into browns;
    /// * 5 or more: X at 345 degrees, the template with the longest arc (187.2 degrees), so the
    ///   most room between classes (23.4 degrees at 8 classes); its sectors run magenta-red-
    ///   orange and green-cyan-azure, again leaving out the yellows and olives.
    pub fn default_for(class_count: usize) -> HueTemplate {
        match class_count {
            0 | 1 => HueTemplate::new(TemplateType::V, 200.0),
            2 => HueTemplate::new(TemplateType::I, 10.0),
            3 | 4 => HueTemplate::new(TemplateType::T, 280.0),
            _ => HueTemplate::new(TemplateType::X, 345.0),
        }
    }

    /// The hue in [0, 360) at arc position `position_degrees` along the concatenated sectors
    /// (clamped to [0, A]; a position on the boundary of two sectors belongs to the second).
    pub fn hue_at_arc(&self, position_degrees: f32) -> f32 {
        let sectors = self.template.sectors();
        let mut rest = position_degrees.clamp(0.0, self.template.arc_length_degrees());
        for (number, sector) in sectors.iter().enumerate() {
            if rest < sector.width_degrees || number + 1 == sectors.len() {
                let low_edge = self.rotation_degrees + sector.centre_offset_degrees - sector.width_degrees / 2.0;
                return (low_edge + rest).rem_euclid(360.0);
            }
            rest -= sector.width_degrees;
        }
        // Every template has a sector; an empty list would leave the rotation as the hue.
        self.rotation_degrees.rem_euclid(360.0)
    }

    /// Width of every class's range for `class_count` classes: 18 degrees while every two
    /// centres are more than 18 degrees apart on the wheel, else 0.9 times the smallest such
    /// distance (so shrunk ranges keep a gap; with centres `A / Z` apart on a sector this
    /// shrinks exactly when `Z * 18 >= A`, ranges on different sectors never force it).
    pub fn range_width_degrees(&self, class_count: usize) -> f32 {
        let centres = self.centre_hues(class_count);
        let closest = centres
            .iter()
            .enumerate()
            .flat_map(|(k, a)| centres[k + 1..].iter().map(move |b| hue_distance_degrees(*a, *b)))
            .fold(f32::INFINITY, f32::min);
        if closest > RANGE_WIDTH_DEGREES { RANGE_WIDTH_DEGREES } else { SHRUNK_FRACTION * closest }
    }

    /// The centre hue, in [0, 360), of each of `class_count` classes.
    pub fn centre_hues(&self, class_count: usize) -> Vec<f32> {
        let arc = self.template.arc_length_degrees();
        (0..class_count).map(|k| self.hue_at_arc(arc * (k as f32 + 0.5) / class_count as f32)).collect()
    }

    /// `[xi_l, xi_h]` of eq. 4 for each class: `xi_l` in [0, 360), `xi_h = xi_l + width` (may
    /// pass 360; hues are read modulo 360).
    pub fn hue_ranges(&self, class_count: usize) -> Vec<[f32; 2]> {
        let width = self.range_width_degrees(class_count);
        self.centre_hues(class_count)
            .into_iter()
            .map(|centre| {
                let low = (centre - width / 2.0).rem_euclid(360.0);
                [low, low + width]
            })
            .collect()
    }
}

/// The distance between two hues on the wheel, in [0, 180].
pub fn hue_distance_degrees(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether two hue ranges (as from `hue_ranges`) share any hue, as arcs of the wheel.
    fn overlap(a: [f32; 2], b: [f32; 2]) -> bool {
        let centre = |r: [f32; 2]| (r[0] + r[1]) / 2.0;
        let half = |r: [f32; 2]| (r[1] - r[0]) / 2.0;
        hue_distance_degrees(centre(a), centre(b)) <= half(a) + half(b) + 1e-3
    }

    #[test]
    fn arc_lengths_match_the_spec() {
        let expected = [18.0, 93.6, 97.2, 36.0, 180.0, 111.6, 187.2];
        for (template, length) in TemplateType::ALL.into_iter().zip(expected) {
            assert!((template.arc_length_degrees() - length).abs() < 1e-4, "{template:?}");
            assert_eq!(TemplateType::from_name(template.name()), Some(template));
        }
        assert_eq!(TemplateType::from_name("x"), None);
    }

    #[test]
    fn walking_the_arc_visits_each_sector_in_turn() {
        let l = HueTemplate::new(TemplateType::L, 100.0);
        assert!((l.hue_at_arc(0.0) - 91.0).abs() < 1e-4, "sector 1 starts 9 below the rotation");
        assert!((l.hue_at_arc(17.9) - 108.9).abs() < 1e-3);
        assert!((l.hue_at_arc(18.0) - 150.4).abs() < 1e-3, "sector 2 starts at 190 - 39.6");
        assert!((l.hue_at_arc(97.2) - 229.6).abs() < 1e-3);
        let x = HueTemplate::new(TemplateType::X, 0.0);
        assert!((x.hue_at_arc(0.0) - 313.2).abs() < 1e-3, "wraps below 0 into [0, 360)");
        assert!((x.hue_at_arc(93.6) - 133.2).abs() < 1e-3);
    }

    #[test]
    fn rotation_turns_every_hue_by_the_same_angle_across_360() {
        for template in TemplateType::ALL {
            let base = HueTemplate::new(template, 0.0);
            for rotation in [0.0f32, 45.0, 179.5, 350.0, 360.0, 725.0, -30.0] {
                let turned = HueTemplate::new(template, rotation);
                for (a, b) in base.centre_hues(5).into_iter().zip(turned.centre_hues(5)) {
                    assert!((0.0..360.0).contains(&b), "{template:?} {rotation}: {b}");
                    let moved = (b - a).rem_euclid(360.0);
                    let expected = rotation.rem_euclid(360.0);
                    assert!(hue_distance_degrees(moved, expected) < 1e-3, "{template:?} {rotation}: {a} -> {b}");
                }
            }
        }
    }

    #[test]
    fn classes_are_spaced_equally_and_never_overlap_on_every_template() {
        for template in TemplateType::ALL {
            for rotation in [0.0, 137.0, 350.0] {
                let hue_template = HueTemplate::new(template, rotation);
                for class_count in 1..=8 {
                    let ranges = hue_template.hue_ranges(class_count);
                    let width = hue_template.range_width_degrees(class_count);
                    assert_eq!(ranges.len(), class_count);
                    let spacing = template.arc_length_degrees() / class_count as f32;
                    assert!(width <= RANGE_WIDTH_DEGREES && width > 0.0);
                    if (class_count as f32) * RANGE_WIDTH_DEGREES < template.arc_length_degrees() {
                        assert_eq!(width, RANGE_WIDTH_DEGREES, "{template:?} x {class_count} fits unshrunk");
                    } else if template.sectors().len() == 1 && class_count > 1 {
                        assert!(width < spacing, "{template:?} x {class_count} shrinks below the spacing");
                    }
                    for (k, range) in ranges.iter().enumerate() {
                        assert!((range[1] - range[0] - width).abs() < 1e-4);
                        // Centres sit at A (k + 0.5) / Z along the arc.
                        let centre = (range[0] + width / 2.0).rem_euclid(360.0);
                        let expected = hue_template.hue_at_arc(spacing * (k as f32 + 0.5));
                        assert!(hue_distance_degrees(centre, expected) < 1e-3);
                        for other in &ranges[k + 1..] {
                            assert!(!overlap(*range, *other), "{template:?} {rotation} x {class_count}: {ranges:?}");
                        }
                    }
                    let centres = hue_template.centre_hues(class_count);
                    for (k, a) in centres.iter().enumerate() {
                        for b in &centres[k + 1..] {
                            assert!(hue_distance_degrees(*a, *b) > 1.0, "{template:?} x {class_count}: {centres:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn default_templates_keep_classes_at_least_20_degrees_apart_with_full_ranges() {
        for class_count in 1..=8 {
            let template = HueTemplate::default_for(class_count);
            assert_eq!(template.range_width_degrees(class_count), RANGE_WIDTH_DEGREES);
            let centres = template.centre_hues(class_count);
            for (k, a) in centres.iter().enumerate() {
                for b in &centres[k + 1..] {
                    assert!(hue_distance_degrees(*a, *b) >= 20.0, "{class_count} classes: {centres:?}");
                }
            }
            // No default range reaches into yellow-olive (55..95), which darkens into browns.
            for range in template.hue_ranges(class_count) {
                for step in 0..=18 {
                    let hue = (range[0] + (range[1] - range[0]) * step as f32 / 18.0).rem_euclid(360.0);
                    assert!(!(55.0..95.0).contains(&hue), "{class_count} classes: {range:?}");
                }
            }
        }
    }
}
