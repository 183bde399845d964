//! The loops' cleaning and the intensity gate (paper §3.2's lassos, §3.3's first feature):
//! each class's band of drawn intensities, the voxels it trains on, and which classes a
//! voxel's intensity allows.
//!
//! The one-vs-one vote (§3.4) lets pairs of classes unlike a voxel outvote the pair that
//! matters (far from the training data a pair's value is little more than its bias). So an
//! intensity one band holds is that class; several bands leave it to their pairs; between bands
//! the band below and the band above vote; beyond every band the classes whose bands end near
//! the outermost end ([`BEYOND_REACH`]), as if it lay at that end
//! (`docs/decisions/0005-intensity-gate.md`).
//!
//! A finger's loop holds a rim of its neighbours: a class whose rim ([`CORE_DEPTH`]) holds
//! another class's intensities ([`LEAKED_RIM_SHARE`]) takes its band, and trains, on its core
//! (`docs/decisions/0006-leaked-rim.md`); a clean loop's enclosed voxels of another class are
//! set aside (`enclosed`).
//!
//! Never: trains, or looks at a voxel's other features; with more than [`MAX_CLASSES`] classes
//! every class is allowed everywhere.

mod enclosed;
mod regions;

use super::neighbours::faces_of;
pub use crate::classify::ClassSet;
use crate::strokes::TrainingSet;
use crate::volume::Volume;
use regions::Regions;

/// Share of a class's drawn voxels left out at each end of its band.
pub const BAND_TRIM: f64 = 0.02;

/// How far a band reaches past its trimmed ends, in robust deviations of the class: narrower
/// loses leaky lassos' worst case (`docs/decisions/0005-intensity-gate.md`).
pub const BAND_MARGIN: f64 = 0.25;

/// How deep a lasso's rim is, in voxels: a finger's loop reaches about two voxels past the
/// structure it circles.
pub const CORE_DEPTH: usize = 2;

/// Fewest voxels a lasso's core needs to stand for the class; with fewer a small class's clean
/// loop loses its rim (`docs/decisions/0006-leaked-rim.md`).
pub const MIN_CORE_VOXELS: usize = 32;

/// Beyond every band, the classes whose band ends within this share of the outermost band's
/// width of its end vote: a joint's partial-volume band past a bone's would take the cortex
/// alone (`docs/decisions/0005-intensity-gate.md`).
pub const BEYOND_REACH: f32 = 0.5;

/// Least share of a class's drawn voxels its core must hold for a leaked class to train on the
/// core alone: a thin vessel's core misses its edge (`docs/decisions/0006-leaked-rim.md`).
pub const CORE_TRAINING_SHARE: f64 = 0.34;

/// Share of a lasso's rim outside its core's band and inside another class's core band that
/// makes the rim leaked (`docs/decisions/0006-leaked-rim.md`).
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

    /// This gate with class `position` allowed nowhere (its band holds no intensity, and no
    /// voxel between or beyond bands goes to it); an open gate stays open.
    pub fn without(&self, position: usize) -> IntensityGate {
        if self.bands.is_empty() || position >= self.bands.len() {
            return self.clone();
        }
        let mut bands = self.bands.clone();
        bands[position] = Band { low: f32::INFINITY, high: f32::NEG_INFINITY };
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
    /// and the nearest above; beyond
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
        (Some(below), Some(above)) => (1 << below) | (1 << above),
        (None, None) => 0,
    }
}

/// The classes whose band `qualifies`.
fn classes_where(bands: &[Band], qualifies: impl Fn(&Band) -> bool) -> ClassSet {
    let qualifying = bands.iter().enumerate().filter(|(_, band)| qualifies(band));
    qualifying.fold(0, |set, (position, _)| set | 1 << position)
}

/// The classes' lassos as drawn, read once for both what they give: the gate's bands
/// ([`bands`](Self::bands)) and the voxels each class trains on
/// ([`training_voxels`](Self::training_voxels)).
pub struct DrawnLassos {
    /// Each class as drawn; `None` when a class has no finite value (the gate is open then).
    classes: Option<Vec<DrawnClass>>,
    /// Per class, whether its rim leaked (empty with `classes`).
    leaked: Vec<bool>,
    /// Number of classes.
    count: usize,
}

impl DrawnLassos {
    /// `training`'s classes as drawn in `volume`.
    pub fn read(volume: &Volume, training: &TrainingSet) -> DrawnLassos {
        let mut classes = drawn_classes(volume, training);
        let leaked = classes.as_deref().map(rims_leaked).unwrap_or_default();
        if let Some(classes) = classes.as_deref() {
            let quartiles: Vec<_> = classes.iter().map(|class| class.core_quartiles).collect();
            log::debug!("lasso cores' quartiles: {quartiles:?}; rims leaked: {leaked:?}");
        }
        if let Some(classes) = classes.as_deref_mut() {
            enclosed::set_aside(volume, training, classes, &leaked);
        }
        DrawnLassos { classes, leaked, count: training.classes.len() }
    }

    /// The gate's bands, in class order: a class whose rim leaked takes its band from its core,
    /// one whose loops enclose another class's voxels from its other voxels; `None` where the
    /// gate is open (a class without a finite value, more than [`MAX_CLASSES`] classes).
    pub fn bands(&self) -> Option<Vec<Band>> {
        let classes = self.classes.as_ref().filter(|_| self.count <= MAX_CLASSES)?;
        let bands: Vec<Band> = classes
            .iter()
            .zip(&self.leaked)
            .map(|(class, &leaked)| match &class.unenclosed {
                _ if leaked => class.core,
                Some((_, band)) => *band,
                None => class.whole,
            })
            .collect();
        log::debug!("intensity bands: {bands:?}");
        Some(bands)
    }

    /// Per class, the voxels (sorted) it should train on: its core when its lasso's rim leaked
    /// and the core is large enough to stand for it (at least [`MIN_CORE_VOXELS`] and
    /// [`CORE_TRAINING_SHARE`] of its drawn voxels), its voxels less those its loops enclose of
    /// another class (`enclosed`); `None` for a class that trains on all of them.
    pub fn training_voxels(&self) -> Vec<Option<&[usize]>> {
        self.per_class(|class, leaked| match &class.unenclosed {
            _ if leaked => class.core_stands_for_it().then_some(class.core_voxels.as_slice()),
            Some((voxels, _)) => Some(voxels.as_slice()),
            None => None,
        })
    }

    /// Per class, the lassoed voxels (sorted) that keep the class whatever the classifier says:
    /// the core of a class that trains on its core; `None` where all of them do (the enclosed
    /// voxels too: the user drew them as this class).
    pub fn decided_voxels(&self) -> Vec<Option<&[usize]>> {
        self.per_class(|class, leaked| (leaked && class.core_stands_for_it()).then_some(class.core_voxels.as_slice()))
    }

    /// `answer` for each class and whether its rim leaked; `None` for every class when a class
    /// has no finite value.
    fn per_class<'a>(
        &'a self,
        answer: impl Fn(&'a DrawnClass, bool) -> Option<&'a [usize]>,
    ) -> Vec<Option<&'a [usize]>> {
        let Some(classes) = &self.classes else {
            return vec![None; self.count];
        };
        classes.iter().zip(&self.leaked).map(|(class, &leaked)| answer(class, leaked)).collect()
    }
}

/// One class's drawn intensities: its whole band, its core's band and quartiles (the whole's
/// when the core is too small; rim and core voxels empty then), and its voxels less those its
/// loops enclose of another class, with their band.
struct DrawnClass {
    whole: Band,
    core: Band,
    core_quartiles: [f64; 3],
    rim: Vec<f64>,
    core_voxels: Vec<usize>,
    drawn_voxels: usize,
    unenclosed: Option<(Vec<usize>, Band)>,
}

/// Each class of `training` as drawn in `volume`; `None` when a class has no finite value.
fn drawn_classes(volume: &Volume, training: &TrainingSet) -> Option<Vec<DrawnClass>> {
    let mut drawn = Vec::with_capacity(training.classes.len());
    for class in &training.classes {
        let mut values = finite_values(volume, &class.voxels);
        let whole = band_of(&mut values)?;
        let core = lasso_core(&class.voxels, volume.dims);
        let mut core_values = finite_values(volume, &core);
        let core_band = (core.len() >= MIN_CORE_VOXELS).then(|| band_of(&mut core_values)).flatten();
        drawn.push(match core_band {
            Some(band) => {
                let rim: Vec<usize> =
                    class.voxels.iter().copied().filter(|voxel| core.binary_search(voxel).is_err()).collect();
                DrawnClass {
                    whole,
                    core: band,
                    core_quartiles: quartiles(&core_values),
                    rim: finite_values(volume, &rim),
                    core_voxels: core,
                    drawn_voxels: class.voxels.len(),
                    unenclosed: None,
                }
            }
            None => DrawnClass {
                whole,
                core: whole,
                core_quartiles: quartiles(&values),
                rim: Vec::new(),
                core_voxels: Vec::new(),
                drawn_voxels: class.voxels.len(),
                unenclosed: None,
            },
        });
    }
    Some(drawn)
}

/// The finite values of `voxels` in `volume`.
fn finite_values(volume: &Volume, voxels: &[usize]) -> Vec<f64> {
    voxels.iter().map(|&voxel| volume.value(voxel)).filter(|v| v.is_finite()).collect()
}

/// For each drawn class, whether its rim leaked ([`DrawnClass::rim_leaked`]).
fn rims_leaked(drawn: &[DrawnClass]) -> Vec<bool> {
    let cores: Vec<(Band, [f64; 3])> = drawn.iter().map(|class| (class.core, class.core_quartiles)).collect();
    drawn.iter().enumerate().map(|(position, class)| class.rim_leaked(position, &cores)).collect()
}

impl DrawnClass {
    /// Whether the lasso's core is large enough to stand for the class: at least
    /// [`MIN_CORE_VOXELS`] (else it is empty) and [`CORE_TRAINING_SHARE`] of its drawn voxels.
    fn core_stands_for_it(&self) -> bool {
        !self.core_voxels.is_empty() && self.core_voxels.len() as f64 >= CORE_TRAINING_SHARE * self.drawn_voxels as f64
    }

    /// Whether more than [`LEAKED_RIM_SHARE`] of the rim lies outside this class's core band
    /// and inside the core band of another class, nearer that class's core median than this
    /// one's unless this one's lies between that class's core quartiles (`cores`: each class's
    /// core band and quartiles, this one at `position`).
    fn rim_leaked(&self, position: usize, cores: &[(Band, [f64; 3])]) -> bool {
        let own_median = self.core_quartiles[1];
        let another_class_s = |value: f64| {
            cores.iter().enumerate().any(|(other, &(band, [low, median, high]))| {
                let own_core_over_it = low <= own_median && own_median <= high;
                other != position
                    && band.holds(value as f32)
                    && ((value - median).abs() < (value - own_median).abs() || own_core_over_it)
            })
        };
        let leaked = self.rim.iter().filter(|&&value| !self.core.holds(value as f32) && another_class_s(value)).count();
        !self.rim.is_empty() && leaked as f64 > LEAKED_RIM_SHARE * self.rim.len() as f64
    }
}

/// The voxels of a lasso (sorted volume indices) more than [`CORE_DEPTH`] voxels from its edge:
/// [`CORE_DEPTH`] times, the voxels with at least four of their six face neighbours in the set
/// (the four in a lasso's own slice; where lassos on two axes cross, any four).
pub(super) fn lasso_core(voxels: &[usize], dims: [usize; 3]) -> Vec<usize> {
    let mut core = voxels.to_vec();
    for _ in 0..CORE_DEPTH {
        let inside = |voxel: usize| core.binary_search(&voxel).is_ok();
        let kept =
            |&voxel: &usize| faces_of(voxel, dims).into_iter().flatten().filter(|&face| inside(face)).count() >= 4;
        core = core.iter().copied().filter(kept).collect();
    }
    core
}

/// The 25, 50 and 75 % quantiles of `sorted` values (at least one).
pub(super) fn quartiles(sorted: &[f64]) -> [f64; 3] {
    [0.25, 0.5, 0.75].map(|share| quantile(sorted, share))
}

/// The value of `sorted` values (at least one) with `share` (0 to 1) of them below it, the
/// nearest rank.
pub(super) fn quantile(sorted: &[f64], share: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * share).round() as usize]
}

/// The band of one class's values (sorted here); `None` without values.
fn band_of(values: &mut [f64]) -> Option<Band> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let at = |share: f64| quantile(values, share);
    let spread = (at(0.95) - at(0.05)) / 3.29;
    let margin = BAND_MARGIN * spread;
    Some(Band { low: (at(BAND_TRIM) - margin) as f32, high: (at(1.0 - BAND_TRIM) + margin) as f32 })
}

#[cfg(test)]
mod tests;
