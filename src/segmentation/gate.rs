//! Which classes a voxel's intensity allows: each class's band of intensities, taken from the
//! voxels its lassos drew (paper §3.2's lassos, §3.3's first feature), and the classes whose
//! band holds the voxel's intensity.
//!
//! The one-vs-one vote (§3.4) lets every pair of classes vote on every voxel, also pairs of
//! which neither class is anything like the voxel; their decision values far from the training
//! data are little more than each pair's bias, and they can outvote the pair that matters. On
//! the foot phantom, air next to the skin (about -900 HU, a steep gradient) lost to the thin
//! joint space (a class of steep gradients) in three pairs and came out soft tissue; on the
//! shells phantom the small seed took half the rind. An intensity the user drew for one class
//! only is that class; a voxel that several bands hold is left to the vote among those classes;
//! one between bands to the vote between the band below and the band above; one beyond every
//! band goes to the class whose band is nearest. Measured with `volasso accuracy`
//! (benches/README.md): on the check cases the mean macro Dice rose from 0.806 to 0.848 with
//! clean lassos and from 0.804 to 0.811 with leaky ones.
//!
//! A band is the class's drawn intensities from the [`BAND_TRIM`] to the 1 - [`BAND_TRIM`]
//! quantile (a few stray voxels at a lasso's edge do not widen it), widened on each side by
//! [`BAND_MARGIN`] of the class's robust spread. The voxels come from the strokes as drawn,
//! before the background rule gives a class's face-air voxels to the air, so a class keeps the
//! intensities the user drew it over (a lasso in lungs that the volume's faces cut).
//!
//! Never: trains, or looks at a voxel's other features; with more than [`MAX_CLASSES`] classes
//! every class is allowed everywhere.

pub use crate::classify::ClassSet;
use crate::strokes::TrainingSet;
use crate::volume::Volume;

/// Share of a class's drawn voxels left out at each end of its band.
pub const BAND_TRIM: f64 = 0.02;

/// How far a band reaches past its trimmed ends, in robust deviations of the class (the 5 to
/// 95 % quantile distance over 3.29, which is one deviation for a normal class). Chosen on the
/// tuning cases among 0, 1/4, 1 and 2: the narrower the band, the better with clean lassos;
/// 1/4 had the best worst case with leaky ones.
pub const BAND_MARGIN: f64 = 0.25;

/// Classes a gate can tell apart (one bit each in a [`ClassSet`], in the model's class order).
pub const MAX_CLASSES: usize = crate::classify::CLASS_SET_CAPACITY;

/// One class's band of intensities, inclusive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Band {
    /// Lowest intensity of the band.
    pub low: f32,
    /// Highest intensity of the band.
    pub high: f32,
}

/// The bands of every class, in the model's class order; none when the gate is open.
#[derive(Clone, Debug, PartialEq)]
pub struct IntensityGate {
    bands: Vec<Band>,
    classes: usize,
}

impl IntensityGate {
    /// Every class allowed for every voxel.
    pub fn open(classes: usize) -> IntensityGate {
        IntensityGate { bands: Vec::new(), classes }
    }

    /// A gate of the given bands, one per class in class order.
    pub fn from_bands(bands: Vec<Band>) -> IntensityGate {
        let classes = bands.len();
        if classes > MAX_CLASSES { IntensityGate::open(classes) } else { IntensityGate { bands, classes } }
    }

    /// The bands of `training`'s classes, in its order, from their voxels' values in `volume`.
    /// Open when a class has no finite value or there are more than [`MAX_CLASSES`] classes.
    pub fn from_drawn(volume: &Volume, training: &TrainingSet) -> IntensityGate {
        let classes = training.classes.len();
        if classes > MAX_CLASSES {
            return IntensityGate::open(classes);
        }
        let mut bands = Vec::with_capacity(classes);
        for class in &training.classes {
            let mut values: Vec<f64> =
                class.voxels.iter().map(|&voxel| volume.value(voxel)).filter(|v| v.is_finite()).collect();
            let Some(band) = band_of(&mut values) else {
                return IntensityGate::open(classes);
            };
            bands.push(band);
        }
        IntensityGate { bands, classes }
    }

    /// Number of classes.
    pub fn classes(&self) -> usize {
        self.classes
    }

    /// The bands, in class order (empty when the gate is open).
    pub fn bands(&self) -> &[Band] {
        &self.bands
    }

    /// Every class position.
    pub fn every_class(&self) -> ClassSet {
        if self.classes >= MAX_CLASSES { ClassSet::MAX } else { (1 << self.classes) - 1 }
    }

    /// The classes `intensity` allows: those whose band holds it; else the nearest band below
    /// and the nearest above (one of them beyond the last band). Empty for a non-finite
    /// intensity.
    pub fn allowed(&self, intensity: f32) -> ClassSet {
        if !intensity.is_finite() {
            return 0;
        }
        if self.bands.is_empty() {
            return self.every_class();
        }
        let mut holding: ClassSet = 0;
        let (mut below, mut above) = ((f32::NEG_INFINITY, None), (f32::INFINITY, None));
        for (position, band) in self.bands.iter().enumerate() {
            if band.low <= intensity && intensity <= band.high {
                holding |= 1 << position;
            } else if band.high < intensity && band.high > below.0 {
                below = (band.high, Some(position));
            } else if band.low > intensity && band.low < above.0 {
                above = (band.low, Some(position));
            }
        }
        if holding != 0 {
            return holding;
        }
        [below.1, above.1].into_iter().flatten().fold(0, |set, position| set | 1 << position)
    }
}

/// The band of one class's values (sorted here); `None` without values.
fn band_of(values: &mut [f64]) -> Option<Band> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let quantile = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
    let spread = (quantile(0.95) - quantile(0.05)) / 3.29;
    let margin = BAND_MARGIN * spread;
    Some(Band { low: (quantile(BAND_TRIM) - margin) as f32, high: (quantile(1.0 - BAND_TRIM) + margin) as f32 })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gate(bands: &[(f32, f32)]) -> IntensityGate {
        IntensityGate::from_bands(bands.iter().map(|&(low, high)| Band { low, high }).collect())
    }

    #[test]
    fn a_band_alone_allows_its_class_and_overlaps_allow_both() {
        let gate = gate(&[(-1000.0, -900.0), (0.0, 100.0), (80.0, 1500.0)]);
        assert_eq!(gate.allowed(-950.0), 0b001);
        assert_eq!(gate.allowed(50.0), 0b010);
        assert_eq!(gate.allowed(90.0), 0b110);
        assert_eq!(gate.allowed(1000.0), 0b100);
    }

    #[test]
    fn between_bands_the_neighbours_on_both_sides_and_beyond_the_last_the_nearest() {
        let gate = gate(&[(-1000.0, -900.0), (0.0, 100.0), (200.0, 300.0)]);
        assert_eq!(gate.allowed(-500.0), 0b011, "between air and soft tissue");
        assert_eq!(gate.allowed(150.0), 0b110);
        assert_eq!(gate.allowed(2000.0), 0b100, "brighter than every band");
        assert_eq!(gate.allowed(-3000.0), 0b001, "darker than every band");
        assert_eq!(gate.allowed(f32::NAN), 0);
    }

    #[test]
    fn an_open_gate_allows_every_class() {
        let gate = IntensityGate::open(3);
        assert_eq!(gate.allowed(12.0), 0b111);
        assert_eq!(IntensityGate::open(70).every_class(), ClassSet::MAX);
        let contains = crate::classify::class_set_contains;
        assert!(contains(ClassSet::MAX, 65) && contains(0b10, 1) && !contains(0b10, 0));
    }

    #[test]
    fn stray_voxels_do_not_widen_a_band_and_the_margin_follows_the_spread() {
        // 100 values 0..99 and one stray voxel at -1000: the 2 % quantile ignores it.
        let mut values: Vec<f64> = (0..100).map(f64::from).chain([-1000.0]).collect();
        let band = band_of(&mut values).unwrap();
        let spread = (95.0 - 5.0) / 3.29;
        assert!((band.low as f64 - (1.0 - BAND_MARGIN * spread)).abs() < 1.5, "{band:?}");
        assert!((band.high as f64 - (97.0 + BAND_MARGIN * spread)).abs() < 1.5, "{band:?}");
        assert_eq!(band_of(&mut []), None);
        let mut flat = vec![7.0; 10];
        assert_eq!(band_of(&mut flat), Some(Band { low: 7.0, high: 7.0 }));
    }
}
