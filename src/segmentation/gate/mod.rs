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
//! one between bands to the vote between the band below and the band above, and the bands
//! that end near those ([`BETWEEN_REACH`]); one beyond every
//! band to the vote among the classes whose bands end near the outermost band's end
//! ([`BEYOND_REACH`]), taken as if it lay at that end (its intensities moved there, its
//! gradient kept), since far from every drawn voxel the vote is little more than each pair's
//! bias. Measured with `volasso accuracy`
//! (benches/README.md): on the check cases the mean macro Dice rose from 0.806 to 0.848 with
//! clean lassos and from 0.804 to 0.811 with leaky ones.
//!
//! A band is the class's drawn intensities from the [`BAND_TRIM`] to the 1 - [`BAND_TRIM`]
//! quantile (a few stray voxels at a lasso's edge do not widen it), widened on each side by
//! [`BAND_MARGIN`] of the class's robust spread. The voxels come from the strokes as drawn,
//! before the background rule gives a class's face-air voxels to the air, so a class keeps the
//! intensities the user drew it over (a lasso in lungs that the volume's faces cut).
//!
//! A finger's loop reaches a voxel or two past the structure it circles, and that rim can be
//! more than the trim: a loop around a thin bone draws as much muscle and fat as bone, and the
//! bone's band then holds the fat, which the gate gives to the bone. So a class whose lasso
//! rim (the voxels within [`CORE_DEPTH`] of its edge) leaked, more than [`LEAKED_RIM_SHARE`] of
//! it outside its own core's band and inside another class's, takes its band from the core
//! alone. A rim that differs from the core but is nobody else's (a bone's bright cortex around
//! its marrow, drawn cleanly) stays in the band, and a lasso too small to have a core of
//! [`MIN_CORE_VOXELS`] keeps every voxel. On the check cases this moved the mean macro Dice
//! with leaky lassos from 0.811 to 0.838, and left the clean ones at 0.848.
//!
//! Never: trains, or looks at a voxel's other features; with more than [`MAX_CLASSES`] classes
//! every class is allowed everywhere.

mod regions;

pub use crate::classify::ClassSet;
use crate::strokes::TrainingSet;
use crate::volume::Volume;
use regions::Regions;

/// Share of a class's drawn voxels left out at each end of its band.
pub const BAND_TRIM: f64 = 0.02;

/// How far a band reaches past its trimmed ends, in robust deviations of the class (the 5 to
/// 95 % quantile distance over 3.29, which is one deviation for a normal class). Chosen on the
/// tuning cases among 0, 1/4, 1 and 2: the narrower the band, the better with clean lassos;
/// 1/4 had the best worst case with leaky ones.
pub const BAND_MARGIN: f64 = 0.25;

/// How deep a lasso's rim is, in voxels: a finger's loop reaches about two voxels past the
/// structure it circles on a 256-voxel slice (as the accuracy harness's leaky hand draws).
pub const CORE_DEPTH: usize = 2;

/// Fewest voxels a lasso's core needs for its band to stand for the class (else the class keeps
/// its whole band). Chosen on the tuning cases among 16, 24, 32 and 40: below 32, a small
/// class's cleanly drawn lasso (the shells' seed) lost its rim and the clean Dice fell.
pub const MIN_CORE_VOXELS: usize = 32;

/// Beyond every band, the classes whose band ends within this share of the outermost band's
/// width of that band's outer end are left to the vote. There intensity no longer tells apart
/// classes whose bands end near each other: a thin class's few partial-volume voxels can carry
/// its band past a larger class's (the foot's joint space past a bone drawn over its marrow,
/// which then lost its cortex to the joint). Chosen on the tuning cases: 0.25, 0.5 and 0.75
/// scored alike; 1 (any band overlapping the outermost) let a leaky soft-tissue band vote on
/// a bone's cortex.
pub const BEYOND_REACH: f32 = 0.5;

/// Between bands, the classes whose bands end within this share of the nearest band's width
/// (below the voxel and above it) of that band's end are left to the vote, for the same
/// reason as [`BEYOND_REACH`]: a bone's leaky loop carried its band's low end a few units past
/// the soft tissue's, and the fat below both went to the bone alone. Chosen on the tuning
/// cases: 0.25 scored best with leaky lassos (+0.0005 on the mean, worst case -0.004), 0.5
/// cost the shells -0.017 on one; clean lassos alike.
pub const BETWEEN_REACH: f32 = 0.25;

/// Share of a lasso's rim that, outside its own core's band and inside another class's core
/// band, makes the rim leaked. Chosen on the tuning cases among 0.1, 0.15, 0.2 and 0.3: the
/// best mean and worst case with leaky lassos, the clean ones unchanged.
pub const LEAKED_RIM_SHARE: f64 = 0.15;

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

impl Band {
    /// Whether the band holds `intensity`.
    pub fn holds(&self, intensity: f32) -> bool {
        self.low <= intensity && intensity <= self.high
    }

    /// `intensity` moved into the band: its nearer end when outside it.
    pub fn clamp(&self, intensity: f32) -> f32 {
        intensity.max(self.low).min(self.high)
    }
}

/// The bands of every class, in the model's class order; none when the gate is open.
#[derive(Clone, Debug, PartialEq)]
pub struct IntensityGate {
    bands: Vec<Band>,
    /// What [`allowed`](Self::allowed) answers, tabulated (empty when the gate is open).
    table: Regions,
    classes: usize,
}

impl IntensityGate {
    /// Every class allowed for every voxel.
    pub fn open(classes: usize) -> IntensityGate {
        IntensityGate { bands: Vec::new(), table: Regions::tabulate([], |_| 0), classes }
    }

    /// A gate of the given bands, one per class in class order.
    pub fn from_bands(bands: Vec<Band>) -> IntensityGate {
        let classes = bands.len();
        if classes > MAX_CLASSES {
            return IntensityGate::open(classes);
        }
        let ends: Vec<f32> = bands.iter().flat_map(|band| [band.low, band.high]).collect();
        let table = Regions::tabulate(ends, |intensity| allowed_by_bands(&bands, intensity));
        IntensityGate { bands, table, classes }
    }

    /// The bands of `training`'s classes, in its order, from their voxels' values in `volume`.
    /// Open when a class has no finite value or there are more than [`MAX_CLASSES`] classes.
    pub fn from_drawn(volume: &Volume, training: &TrainingSet) -> IntensityGate {
        let classes = training.classes.len();
        if classes > MAX_CLASSES {
            return IntensityGate::open(classes);
        }
        let values_of = |voxels: &[usize]| -> Vec<f64> {
            voxels.iter().map(|&voxel| volume.value(voxel)).filter(|v| v.is_finite()).collect()
        };
        let mut drawn = Vec::with_capacity(classes);
        for class in &training.classes {
            let Some(whole) = band_of(&mut values_of(&class.voxels)) else {
                return IntensityGate::open(classes);
            };
            let core = lasso_core(&class.voxels, volume.dims);
            let core_band = (core.len() >= MIN_CORE_VOXELS).then(|| band_of(&mut values_of(&core))).flatten();
            let (core_band, rim) = match core_band {
                Some(band) => {
                    let rim: Vec<usize> =
                        class.voxels.iter().copied().filter(|voxel| core.binary_search(voxel).is_err()).collect();
                    (band, values_of(&rim))
                }
                None => (whole, Vec::new()),
            };
            drawn.push(DrawnClass { whole, core: core_band, rim });
        }
        let cores: Vec<Band> = drawn.iter().map(|class| class.core).collect();
        let bands = drawn
            .iter()
            .enumerate()
            .map(|(position, class)| if class.rim_leaked(position, &cores) { class.core } else { class.whole })
            .collect();
        log::debug!("intensity bands: {bands:?}");
        IntensityGate::from_bands(bands)
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
    /// and the nearest above, with the bands that end near them ([`BETWEEN_REACH`]); beyond
    /// every band, the outermost band's class and the classes whose bands end near its end
    /// ([`BEYOND_REACH`]). Empty for a non-finite intensity.
    pub fn allowed(&self, intensity: f32) -> ClassSet {
        if !intensity.is_finite() {
            return 0;
        }
        if self.bands.is_empty() {
            return self.every_class();
        }
        self.table.set_of(intensity)
    }

    /// From the lowest band's low to the highest band's high: a voxel beyond it is voted on as
    /// if it lay at its nearer end ([`Band::clamp`]); `None` when the gate is open.
    pub fn drawn_range(&self) -> Option<Band> {
        let low = self.bands.iter().map(|band| band.low).min_by(f32::total_cmp)?;
        let high = self.bands.iter().map(|band| band.high).max_by(f32::total_cmp)?;
        Some(Band { low, high })
    }
}

/// [`IntensityGate::allowed`] from `bands` (at least one; a finite `intensity`).
fn allowed_by_bands(bands: &[Band], intensity: f32) -> ClassSet {
    let mut holding: ClassSet = 0;
    let (mut below, mut above) = ((f32::NEG_INFINITY, None), (f32::INFINITY, None));
    for (position, band) in bands.iter().enumerate() {
        if band.holds(intensity) {
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
    match (below.1, above.1) {
        (Some(top), None) => {
            let outermost = bands[top];
            let reach = outermost.high - BEYOND_REACH * (outermost.high - outermost.low);
            classes_where(bands, |band| band.high >= reach)
        }
        (None, Some(bottom)) => {
            let outermost = bands[bottom];
            let reach = outermost.low + BEYOND_REACH * (outermost.high - outermost.low);
            classes_where(bands, |band| band.low <= reach)
        }
        (Some(below), Some(above)) => {
            let (below, above) = (bands[below], bands[above]);
            let reach_below = below.high - BETWEEN_REACH * (below.high - below.low);
            let reach_above = above.low + BETWEEN_REACH * (above.high - above.low);
            classes_where(bands, |band| {
                (reach_below..intensity).contains(&band.high) || (intensity..=reach_above).contains(&band.low)
            })
        }
        (None, None) => 0,
    }
}

/// The classes whose band `qualifies`.
fn classes_where(bands: &[Band], qualifies: impl Fn(&Band) -> bool) -> ClassSet {
    let qualifying = bands.iter().enumerate().filter(|(_, band)| qualifies(band));
    qualifying.fold(0, |set, (position, _)| set | 1 << position)
}

/// One class's drawn intensities: the band of all its voxels, the band of its lassos' core
/// (the same band when the core is too small), and the rim's intensities (empty then).
struct DrawnClass {
    whole: Band,
    core: Band,
    rim: Vec<f64>,
}

impl DrawnClass {
    /// Whether more than [`LEAKED_RIM_SHARE`] of the rim lies outside this class's core band
    /// and inside the core band of another class (`cores`, this one at `position`).
    fn rim_leaked(&self, position: usize, cores: &[Band]) -> bool {
        let leaked = self
            .rim
            .iter()
            .map(|&value| value as f32)
            .filter(|&value| {
                !self.core.holds(value)
                    && cores.iter().enumerate().any(|(other, band)| other != position && band.holds(value))
            })
            .count();
        !self.rim.is_empty() && leaked as f64 > LEAKED_RIM_SHARE * self.rim.len() as f64
    }
}

/// The voxels of a lasso (sorted volume indices) more than [`CORE_DEPTH`] voxels from its edge:
/// [`CORE_DEPTH`] times, the voxels with at least four of their six face neighbours in the set
/// (the four in a lasso's own slice; where lassos on two axes cross, any four).
fn lasso_core(voxels: &[usize], dims: [usize; 3]) -> Vec<usize> {
    let [size_x, size_y, size_z] = dims;
    let plane = size_x * size_y;
    let mut core = voxels.to_vec();
    for _ in 0..CORE_DEPTH {
        let inside = |voxel: usize| core.binary_search(&voxel).is_ok();
        core = core
            .iter()
            .copied()
            .filter(|&voxel| {
                let (x, y, z) = (voxel % size_x, voxel / size_x % size_y, voxel / plane);
                let neighbours = [
                    x > 0 && inside(voxel - 1),
                    x + 1 < size_x && inside(voxel + 1),
                    y > 0 && inside(voxel - size_x),
                    y + 1 < size_y && inside(voxel + size_x),
                    z > 0 && inside(voxel - plane),
                    z + 1 < size_z && inside(voxel + plane),
                ];
                neighbours.iter().filter(|&&neighbour| neighbour).count() >= 4
            })
            .collect();
    }
    core
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
    fn between_bands_the_neighbours_on_both_sides_and_beyond_them_the_outermost() {
        let gate = gate(&[(-1000.0, -900.0), (0.0, 100.0), (200.0, 300.0)]);
        assert_eq!(gate.allowed(-500.0), 0b011, "between air and soft tissue");
        assert_eq!(gate.allowed(150.0), 0b110);
        assert_eq!(gate.allowed(2000.0), 0b100, "brighter than every band");
        assert_eq!(gate.allowed(-3000.0), 0b001, "darker than every band");
        assert_eq!(gate.allowed(f32::NAN), 0);
    }

    #[test]
    fn the_tabulated_gate_answers_as_its_bands_do() {
        let mut rng = crate::rng::SplitMix64::new(9);
        for _ in 0..200 {
            let bands: Vec<(f32, f32)> = (0..1 + rng.below(6))
                .map(|_| {
                    let low = rng.below(200) as f32 - 100.0;
                    (low, low + rng.below(80) as f32)
                })
                .collect();
            let gate = gate(&bands);
            for intensity in (-120..=200).map(|v| v as f32).chain([0.5, -99.25, 1e9, -1e9]) {
                assert_eq!(
                    gate.allowed(intensity),
                    allowed_by_bands(&gate.bands, intensity),
                    "{bands:?} at {intensity}"
                );
            }
        }
    }

    #[test]
    fn between_bands_the_bands_ending_near_the_nearest_ones_are_allowed_too() {
        // Air, soft tissue drawn over muscle, and a bone whose leaky loop carried its band a
        // little below the muscle's: fat, darker than both, is left to the vote of all three.
        let leaky = gate(&[(-1030.0, -970.0), (6.0, 77.0), (-54.0, 1549.0)]);
        assert_eq!(leaky.allowed(-80.0), 0b111);
        // A band that ends far from the nearest stays out.
        let far = gate(&[(-1030.0, -970.0), (6.0, 77.0), (-54.0, 46.0)]);
        assert_eq!(far.allowed(-80.0), 0b101);
    }

    #[test]
    fn beyond_every_band_the_classes_whose_bands_end_near_the_outermost_end_are_allowed() {
        // A thin joint's band reaches past a bone drawn over its marrow: the cortex, brighter
        // than both, is left to the vote of the two, never to soft tissue.
        let foot = gate(&[(0.0, 90.0), (200.0, 370.0), (200.0, 450.0)]);
        assert_eq!(foot.allowed(1300.0), 0b110);
        // A leaky vessel band overlaps the bone's lower half only: the cortex stays the bone's.
        let torso = gate(&[(200.0, 290.0), (240.0, 820.0)]);
        assert_eq!(torso.allowed(1300.0), 0b10);
        // Darker than every band, the same from below.
        let dark = gate(&[(-1000.0, -900.0), (-980.0, -700.0), (0.0, 100.0)]);
        assert_eq!(dark.allowed(-1100.0), 0b011);
        assert_eq!(dark.drawn_range(), Some(Band { low: -1000.0, high: 100.0 }));
        assert_eq!(Band { low: -1000.0, high: 100.0 }.clamp(1300.0), 100.0);
    }

    #[test]
    fn an_open_gate_allows_every_class() {
        let gate = IntensityGate::open(3);
        assert_eq!(gate.allowed(12.0), 0b111);
        assert_eq!(IntensityGate::open(70).every_class(), ClassSet::MAX);
        let contains = crate::classify::class_set_contains;
        assert!(contains(ClassSet::MAX, 65) && contains(0b10, 1) && !contains(0b10, 0));
    }

    const DIMS: [usize; 3] = [40, 40, 3];

    /// A class of the square `x`, `y` on plane 1, one stroke.
    fn square(x: std::ops::Range<usize>, y: std::ops::Range<usize>) -> crate::strokes::ClassSamples {
        let mut voxels: Vec<usize> = y.flat_map(|y| x.clone().map(move |x| x + DIMS[0] * (y + DIMS[1]))).collect();
        voxels.sort_unstable();
        crate::strokes::ClassSamples::one_stroke("class".into(), voxels)
    }

    /// Muscle (40) everywhere, a bone of `marrow` inside x, y 10..20 with a cortex of `cortex`
    /// one voxel thick around it, and a little noise.
    fn bone_in_muscle(marrow: f32, cortex: f32) -> Volume {
        let mut values = vec![40.0f32; DIMS.iter().product()];
        for (index, value) in values.iter_mut().enumerate() {
            let (x, y) = (index % DIMS[0], index / DIMS[0] % DIMS[1]);
            if (10..20).contains(&x) && (10..20).contains(&y) {
                let edge = x == 10 || x == 19 || y == 10 || y == 19;
                *value = if edge { cortex } else { marrow };
            }
            *value += (index % 7) as f32;
        }
        Volume::from_f32(DIMS, [1.0; 3], &values, std::path::Path::new("t")).unwrap()
    }

    #[test]
    fn a_lasso_core_is_two_voxels_inside_its_edge() {
        let class = square(5..16, 5..16);
        let core = lasso_core(&class.voxels, DIMS);
        assert_eq!(core, square(7..14, 7..14).voxels);
        assert!(lasso_core(&square(0..3, 0..40).voxels, DIMS).is_empty());
    }

    #[test]
    fn a_loop_that_leaked_into_its_neighbour_takes_its_band_from_its_core() {
        // The bone's loop (x, y 8..22) reaches two voxels into the muscle around the bone: a
        // third of its voxels. Its band comes from its core: muscle is muscle's alone.
        let volume = bone_in_muscle(1000.0, 1000.0);
        let set = TrainingSet { classes: vec![square(25..36, 25..36), square(8..22, 8..22)], contested_voxels: 0 };
        let gate = IntensityGate::from_drawn(&volume, &set);
        let [muscle, bone] = gate.bands() else { panic!("{gate:?}") };
        assert!(bone.low > 900.0 && muscle.holds(43.0), "{gate:?}");
        assert_eq!(gate.allowed(43.0), 0b01);
        // The same loop with the muscle's class not drawn: the rim is nobody else's, and the
        // bone keeps it.
        let alone = TrainingSet { classes: vec![square(8..22, 8..22)], contested_voxels: 0 };
        assert!(IntensityGate::from_drawn(&volume, &alone).bands()[0].holds(43.0));
    }

    #[test]
    fn a_rim_that_differs_from_the_core_but_is_nobody_elses_stays_in_the_band() {
        // A clean loop just inside the bone (x, y 10..20): its rim is the bright cortex, its
        // core the marrow; the cortex is no other class's, so the band keeps both.
        let volume = bone_in_muscle(300.0, 1400.0);
        let set = TrainingSet { classes: vec![square(25..36, 25..36), square(10..20, 10..20)], contested_voxels: 0 };
        let gate = IntensityGate::from_drawn(&volume, &set);
        let bone = gate.bands()[1];
        assert!(bone.holds(303.0) && bone.holds(1403.0), "{gate:?}");
        // A loop too small for a core of MIN_CORE_VOXELS keeps all its voxels too.
        let small = TrainingSet { classes: vec![square(25..36, 25..36), square(8..15, 8..15)], contested_voxels: 0 };
        assert!(lasso_core(&small.classes[1].voxels, DIMS).len() < MIN_CORE_VOXELS);
        assert!(IntensityGate::from_drawn(&volume, &small).bands()[1].holds(43.0));
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
