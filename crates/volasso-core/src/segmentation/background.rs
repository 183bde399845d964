//! The background: which voxels are air (label 0, never evaluated). Every rule is relative to
//! the volume and to the classes' own intensities (`docs/decisions/0008-background.md`).
//!
//! Automatic rule ([`plan`]): the dark level is the volume's Otsu threshold
//! ([`Volume::otsu_threshold`]), or a second split below it where Otsu's cuts through a lassoed
//! tissue (`dark_level`); the face air is what lies outside the body ([`Volume::body_at`]) at a
//! level: the air around it, joined to the volume's faces (the body rings its lungs and sinuses).
//! 1. A class with at least [`AIR_CLASS_SHARE`] of its voxels in the face air is the air: the
//!    air around the body is that class (the first, where two were drawn there; both train),
//!    the other classes lose their face-air voxels, and inside the body voxels darker than
//!    every other class's are background.
//! 2. Otherwise every lassoed voxel trains its class. The threshold is lowered to the darkest
//!    lassoed voxel inside the body, the face air's level to the darkest one in it (never below
//!    [`air_top`], opening at most [`FACE_AIR_OPENED_SHARE`] of the dark voxels).
//!
//! Never: trains, labels voxels (it hands the threshold and the region to the labelling), or
//! drops a lassoed voxel of a class unless another class was drawn in the air.

use crate::strokes::TrainingSet;
use crate::volume::Volume;
use crate::volume::body::Body;
use std::sync::Arc;

/// A class with at least this share of its voxels in the face air was drawn in the air; a loop
/// around a structure at the body's edge holds less (`docs/decisions/0008-background.md`).
pub const AIR_CLASS_SHARE: f64 = 0.9;

/// Robust deviations above the median of the dark face voxels where the air on the faces ends
/// ([`upper_reach`]).
pub const AIR_REACH_DEVIATIONS: f64 = 3.0;

/// The least Otsu separability for the split below the volume's level to be the dark level;
/// below it the split cuts the air's own noise (`docs/decisions/0008-background.md`).
pub const SEPARATE_POPULATIONS: f64 = 0.8;

/// Share of the dark voxels on the faces below the top of the air ([`air_top`]).
pub const AIR_TOP_QUANTILE: f64 = 0.999;

/// Most of the volume's dark voxels that lowering the face air's level to a class's dim edge
/// may open; a leaky loop that kept an 8-bit scan's air opens more
/// (`docs/decisions/0008-background.md`).
pub const FACE_AIR_OPENED_SHARE: f64 = 0.025;

/// How the background is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    /// The automatic rule of the module doc.
    Automatic,
    /// Voxels below this physical value are background (lassoed voxels are kept as drawn).
    Below(f64),
    /// Every voxel is classified.
    None,
}

/// What the background rule decided for one training set.
#[derive(Clone, Debug, Default)]
pub struct BackgroundPlan {
    /// Voxels below this value are background; `None` when every voxel is classified.
    pub threshold: Option<f64>,
    /// Voxels outside this body (the face air) are background too, or the air class where there
    /// is one; `None` when the threshold alone decides.
    pub body: Option<Arc<Body>>,
    /// Training voxels dropped per class as the air class's (in the face air).
    pub dropped_per_class: Vec<usize>,
    /// A class was drawn in the air around the body.
    pub air_is_a_class: bool,
    /// That class's position: the air around the body (`face_air`) is that class, and no voxel
    /// inside the body is (a windowed chest's lungs stay the lungs).
    pub air_class: Option<usize>,
}

/// Applies `background` to `training` on `volume`: the training set without the voxels the
/// rule drops, and what it decided.
pub fn plan(volume: &Volume, training: &TrainingSet, background: Background) -> (TrainingSet, BackgroundPlan) {
    let unchanged = |threshold| BackgroundPlan {
        threshold,
        dropped_per_class: vec![0; training.classes.len()],
        ..BackgroundPlan::default()
    };
    match background {
        Background::Below(value) => (training.clone(), unchanged(Some(value))),
        Background::None => (training.clone(), unchanged(None)),
        Background::Automatic => automatic(volume, training),
    }
}

fn automatic(volume: &Volume, training: &TrainingSet) -> (TrainingSet, BackgroundPlan) {
    let values: Vec<Vec<f64>> =
        training.classes.iter().map(|class| class.voxels.iter().map(|&v| volume.value(v)).collect()).collect();
    let (level, face_flags) = dark_level(volume, training, &values);
    if !values.iter().flatten().any(|&value| value < level) {
        // The common case: every lassoed voxel lies above the dark level.
        let lowest = values.iter().flatten().copied().fold(level, f64::min);
        let plan = BackgroundPlan {
            threshold: Some(lowest),
            dropped_per_class: vec![0; training.classes.len()],
            ..BackgroundPlan::default()
        };
        return (training.clone(), plan);
    }
    let air_class = face_flags.iter().position(|flags| drawn_in_the_air(flags));
    let air_is_a_class = air_class.is_some();

    let mut classes = Vec::with_capacity(training.classes.len());
    let mut dropped_per_class = Vec::with_capacity(training.classes.len());
    let mut lowest_kept = level;
    let mut lowest_kept_in_face_air = level;
    for ((class, values), flags) in training.classes.iter().zip(&values).zip(&face_flags) {
        // Another class is the air: this class's face air belongs to it.
        let is_air_class = drawn_in_the_air(flags);
        let keep: Vec<bool> = flags.iter().map(|&f| is_air_class || !air_is_a_class || !f).collect();
        // Kept dark voxels lower the threshold inside the body, the face air's level in it.
        for ((&value, &kept), &in_face_air) in values.iter().zip(&keep).zip(flags) {
            if kept && !in_face_air {
                lowest_kept = lowest_kept.min(value);
            } else if kept {
                lowest_kept_in_face_air = lowest_kept_in_face_air.min(value);
            }
        }
        dropped_per_class.push(keep.iter().filter(|&&k| !k).count());
        classes.push(class.retaining(&keep));
    }
    let cleaned = TrainingSet { classes, contested_voxels: training.contested_voxels };
    let plan = if air_is_a_class {
        // The air class's region reaches midway to the darkest brighter class (a windowed CT's
        // fat under the skin is not air), at least to the top of the air as drawn.
        let median = |position: usize| finite_median(values[position].iter().copied());
        let air_median = air_class.and_then(median);
        // Classes as dark as the air (a windowed CT's lungs) are inside the body, not its edge.
        let darkest_other = (0..values.len())
            .filter(|&position| Some(position) != air_class)
            .filter_map(median)
            .filter(|&other| air_median.is_some_and(|air| other > air))
            .fold(f64::INFINITY, f64::min);
        let air_level = match air_median {
            Some(air) if darkest_other.is_finite() && air < darkest_other => {
                // An MRI's noisy air reaches far above its median.
                let top = air_class.map_or(f64::NEG_INFINITY, |position| drawn_top(&values[position]));
                level.min(((air + darkest_other) / 2.0).max(top))
            }
            _ => level,
        };
        let body = Some(volume.body_at(air_level));
        // Inside the body, voxels darker than every other class's kept voxels are background.
        let lowest_other = cleaned
            .classes
            .iter()
            .enumerate()
            .filter(|&(position, _)| Some(position) != air_class)
            .flat_map(|(_, class)| class.voxels.iter().map(|&voxel| volume.value(voxel)))
            .filter(|value| value.is_finite())
            .fold(f64::INFINITY, f64::min);
        let threshold = lowest_other.is_finite().then_some(lowest_other.min(air_level));
        BackgroundPlan { threshold, body, dropped_per_class, air_is_a_class, air_class }
    } else {
        // Everything is classified down to the darkest kept voxel, except the face air (below
        // its own level, lowered to a class's dim edge in it).
        let face_level = lowered_face_level(volume, level, lowest_kept_in_face_air);
        let threshold = lowest_kept.min(face_level);
        let body = (threshold < face_level).then(|| volume.body_at(face_level));
        log::debug!("background: dark level {level}, face air below {face_level}, threshold {threshold}");
        BackgroundPlan { threshold: Some(threshold), body, dropped_per_class, air_is_a_class, air_class: None }
    };
    (cleaned, plan)
}

/// The volume's dark level: its Otsu threshold, or the split below it ([`Volume::split_below`])
/// where Otsu's cuts through a lassoed tissue (a scan of air with one small, very bright
/// structure; an MRI's thin dark skull). The split is tried when a class has [`AIR_CLASS_SHARE`]
/// of its voxels in the face air, else when a lasso core's median lies below Otsu's level, and
/// is the level when all of these hold (`docs/decisions/0008-background.md`):
/// * without a face-air class, some such core lies above it (a loop mostly in air has an air core);
/// * its separability reaches [`SEPARATE_POPULATIONS`], or a face-air class lies above
///   [`upper_reach`];
/// * at least half the dark face voxels lie below it;
/// * no class then has [`AIR_CLASS_SHARE`] of its voxels in the face air.
///
/// Returns the level and each class's [`face_air_flags`] at it, read on the way.
fn dark_level(volume: &Volume, training: &TrainingSet, values: &[Vec<f64>]) -> (f64, Vec<Vec<bool>>) {
    let otsu = volume.otsu_threshold();
    // The face-air classes' medians; else the lasso cores' medians below the level.
    let at_otsu = face_air_flags(volume, training, values, otsu);
    let in_face_air: Vec<f64> = at_otsu
        .iter()
        .zip(values)
        .filter(|(flags, _)| drawn_in_the_air(flags))
        .map(|(_, values)| median_in_place(&mut values.clone()))
        .collect();
    let cores_below: Vec<f64> = if in_face_air.is_empty() {
        let reaching_below = training.classes.iter().zip(values).filter(|(_, values)| values.iter().any(|&v| v < otsu));
        reaching_below.filter_map(|(class, _)| core_median(volume, &class.voxels).filter(|&core| core < otsu)).collect()
    } else {
        Vec::new()
    };
    if in_face_air.is_empty() && cores_below.is_empty() {
        return (otsu, at_otsu);
    }
    let Some(split) = volume.split_below(otsu) else { return (otsu, at_otsu) };
    // A core must lie above the split: a loop mostly in the air has the air for its core.
    if in_face_air.is_empty() && !cores_below.iter().any(|&core| core > split.level) {
        return (otsu, at_otsu);
    }
    let face_dark: Vec<f64> = face_values(volume).into_iter().filter(|&v| v < otsu).collect();
    let face_air_top = upper_reach(face_dark.clone());
    let unlike_the_face_air = in_face_air.iter().any(|&median| face_air_top.is_some_and(|top| median > top));
    if split.separability < SEPARATE_POPULATIONS && !unlike_the_face_air {
        return (otsu, at_otsu);
    }
    let face_below = face_dark.iter().filter(|&&v| v < split.level).count();
    if 2 * face_below < face_dark.len() {
        return (otsu, at_otsu);
    }
    let at_split = face_air_flags(volume, training, values, split.level);
    if at_split.iter().any(|flags| drawn_in_the_air(flags)) {
        return (otsu, at_otsu);
    }
    (split.level, at_split)
}

/// The median of the finite values of a lasso's core (its voxels past a finger's leak,
/// [`super::gate::lasso_core`]); `None` when the core is too small to stand for the class.
fn core_median(volume: &Volume, voxels: &[usize]) -> Option<f64> {
    let core = super::gate::lasso_core(voxels, volume.dims);
    let mut values: Vec<f64> = core.iter().map(|&v| volume.value(v)).filter(|v| v.is_finite()).collect();
    (values.len() >= super::gate::MIN_CORE_VOXELS).then(|| median_in_place(&mut values))
}

/// For each class, whether each of its voxels (`values` are theirs) lies in the face air at
/// `level`: below it and outside the body.
fn face_air_flags(volume: &Volume, training: &TrainingSet, values: &[Vec<f64>], level: f64) -> Vec<Vec<bool>> {
    let body = volume.body_at(level);
    let outside = |(&voxel, &value): (&usize, &f64)| value < level && !body.contains(voxel);
    training
        .classes
        .iter()
        .zip(values)
        .map(|(class, values)| class.voxels.iter().zip(values).map(outside).collect())
        .collect()
}

/// Whether a class with these [`face_air_flags`] was drawn in the air: at least
/// [`AIR_CLASS_SHARE`] of its voxels lie in the face air.
fn drawn_in_the_air(flags: &[bool]) -> bool {
    !flags.is_empty() && flags.iter().filter(|&&flag| flag).count() as f64 >= AIR_CLASS_SHARE * flags.len() as f64
}

/// The top of the air on the faces: the median of `face_dark` (the dark face voxels) plus
/// [`AIR_REACH_DEVIATIONS`] robust deviations; `None` when empty. A class above it was drawn in a
/// dark tissue joined to the air (foam, lungs the faces cut), not in the air.
fn upper_reach(mut face_dark: Vec<f64>) -> Option<f64> {
    if face_dark.is_empty() {
        return None;
    }
    let median = median_in_place(&mut face_dark);
    let mut deviations: Vec<f64> = face_dark.iter().map(|&v| (v - median).abs()).collect();
    Some(median + AIR_REACH_DEVIATIONS * (1.4826 * median_in_place(&mut deviations)))
}

/// The face air's level lowered to `lowest_kept` (the darkest kept voxel in it), never below
/// [`air_top`]; `level` itself when that opens more than [`FACE_AIR_OPENED_SHARE`] of the
/// volume's dark voxels (then the kept voxels are the air's own, not a class's dim edge).
fn lowered_face_level(volume: &Volume, level: f64, lowest_kept: f64) -> f64 {
    if lowest_kept >= level {
        return level;
    }
    let face_dark: Vec<f64> = face_values(volume).into_iter().filter(|&v| v < level).collect();
    let Some(top) = air_top(face_dark) else { return level };
    let lowered = lowest_kept.max(top);
    if lowered >= level {
        return level;
    }
    let (mut dark, mut opened) = (0usize, 0usize);
    let mut slab = vec![0f32; 1 << 16];
    for start in (0..volume.voxel_count()).step_by(1 << 16) {
        let slab = &mut slab[..(volume.voxel_count() - start).min(1 << 16)];
        volume.read_f32(start, slab);
        for value in slab.iter().map(|&value| f64::from(value)).filter(|&value| value < level) {
            dark += 1;
            opened += usize::from(value >= lowered);
        }
    }
    let share = opened as f64 / dark.max(1) as f64;
    log::debug!("face air: lowering its level from {level} to {lowered} opens {share:.4} of the dark voxels");
    if share > FACE_AIR_OPENED_SHARE { level } else { lowered }
}

/// The top of the air on the faces: the higher of [`upper_reach`] and the [`AIR_TOP_QUANTILE`]
/// of `face_dark` (an MRI's air noise has a long tail); `None` when empty.
fn air_top(mut face_dark: Vec<f64>) -> Option<f64> {
    let reach = upper_reach(face_dark.clone())?;
    let rank = ((face_dark.len() - 1) as f64 * AIR_TOP_QUANTILE).round() as usize;
    Some(reach.max(*face_dark.select_nth_unstable_by(rank, f64::total_cmp).1))
}

/// The top of the air an air class drew: the [`AIR_CLASS_SHARE`] quantile of its values (the
/// rest may be the body its loop touched); minus infinity without a finite value.
fn drawn_top(values: &[f64]) -> f64 {
    let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return f64::NEG_INFINITY;
    }
    let rank = ((finite.len() - 1) as f64 * AIR_CLASS_SHARE).round() as usize;
    *finite.select_nth_unstable_by(rank, f64::total_cmp).1
}

/// The values of the voxels on the volume's six faces (edges and corners more than once).
fn face_values(volume: &Volume) -> Vec<f64> {
    let [nx, ny, nz] = volume.dims;
    let mut values = Vec::with_capacity(2 * (nx * ny + ny * nz + nx * nz));
    for z in 0..nz {
        for y in 0..ny {
            if z == 0 || y == 0 || z + 1 == nz || y + 1 == ny {
                values.extend((0..nx).map(|x| volume.value_at(x, y, z)));
            } else {
                values.push(volume.value_at(0, y, z));
                values.push(volume.value_at(nx - 1, y, z));
            }
        }
    }
    values
}

/// The median of the finite `values`; `None` without any.
pub(super) fn finite_median(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let mut finite: Vec<f64> = values.into_iter().filter(|value| value.is_finite()).collect();
    (!finite.is_empty()).then(|| median_in_place(&mut finite))
}

/// The median (upper median for an even count) of a non-empty slice, reordering it.
pub(super) fn median_in_place(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let middle = values.len() / 2;
    *values.select_nth_unstable_by(middle, f64::total_cmp).1
}

#[cfg(test)]
mod situations;
#[cfg(test)]
mod tests;
