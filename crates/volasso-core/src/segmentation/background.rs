//! The background: which voxels are air (label 0, never evaluated), and which lassoed voxels
//! are air that a finger took in rather than the class the user meant (paper §3.2's lassos as
//! they are drawn: a loop *around* a structure at the body's edge holds air too).
//!
//! Automatic rule ([`plan`]). The volume's dark level is its Otsu threshold
//! ([`Volume::otsu_threshold`], which splits air from everything else in CT and MRI alike),
//! or a second split below it where that one cuts through a lassoed tissue (a scan of air
//! with one small, very bright structure; an MRI's thin dark skull that the faces cut, drawn
//! with a finger's leak; see `dark_level`); the *face air* is the dark region joined to the
//! volume's faces outside the scanned body ([`super::face_air`]: a dark region the body rings
//! in its axial slices, such as the lungs that leave a chest CT through its top face, is not
//! face air, however dark a windowed scan makes it).
//! 1. A class with at least [`AIR_CLASS_SHARE`] of its voxels in the face air was drawn in the
//!    air: the user means air as a class. Other classes' face-air voxels are that class's.
//! 2. Otherwise each class is cleaned: its voxels outside the face air are its reference, and
//!    a dark voxel that is a low outlier for that reference (below its median by more than
//!    [`OUTLIER_DEVIATIONS`] robust deviations of its lower half, `1.4826 x` the median
//!    distance below the median) is dropped, inside the face air or not. Dark voxels that
//!    continue the class's own distribution stay (a scan cropped inside the body, where a dark
//!    tissue touches the faces; a lasso in the lungs).
//! 3. When air is a class, the air around the body (the dark region joined to the faces, up
//!    to midway between the air's drawn intensities and the darkest class brighter than it) is
//!    that class by construction, and the classifier never gives it to a voxel inside the body:
//!    a windowed chest's lungs, as dark as the air, stay the lungs. Voxels darker than every
//!    other class's are background (nor evaluated: the air costs the classifier nothing).
//!    Otherwise the threshold is the dark
//!    level, lowered to the darkest kept voxel inside the body, so that no such training
//!    voxel falls into the background (a lasso in the lungs or the sinuses); the face air
//!    stays background all the same. Kept voxels in the face air (a dim edge that continues a
//!    class: a skull-stripped brain's outer CSF, below Otsu's level and joined to the air
//!    around it) lower the face air's level to the darkest of them, never below the top of
//!    the air on the faces ([`air_top`]) and only where that opens no more than
//!    [`FACE_AIR_OPENED_SHARE`] of the face air: the tissue the user drew there is classified
//!    and the air stays background: a skull-stripped brain's clean CSF loop keeps its outer
//!    CSF (`docs/decisions/0008-background.md`).
//!
//! Dark structures that the volume's faces cut (lungs in a chest cut through them), or that
//! join the air at a body's edge (a phantom's foam, bedding), are face air at Otsu's level; a
//! lasso in them moves the level to the split between them and the air when that split is
//! clear or the lasso's voxels are unlike the air on the faces (their median well above it),
//! and is otherwise air drawn as a class (every voxel classified).
//!
//! So one stray dark voxel at a lasso's edge can no longer pull the air into a class: it is an
//! outlier for its class and is dropped. Every rule is relative to the volume (its Otsu level,
//! its faces) and to each class's own intensities, so it holds for 8- and 16-bit scans, CT in
//! Hounsfield units and MRI with a bias field, any number of classes, bodies cut by the faces
//! (air still touches some face) and scans without air (nothing dark touches a face, or what
//! does continues a class).
//!
//! Never: trains, or labels voxels (it hands the threshold and the region to the labelling).

use super::face_air::{FaceRegion, reaches_face};
use crate::strokes::TrainingSet;
use crate::volume::Volume;
use std::sync::Arc;

mod level;

/// A class with at least this share of its voxels in the face air was drawn in the air: a
/// loop around a structure at the body's edge holds less (the structure is what it is drawn
/// around), a loop in the air touches the body with at most its rim.
pub const AIR_CLASS_SHARE: f64 = 0.9;

/// A dark training voxel more than this many robust deviations below its class's median is an
/// outlier for the class (for a normal class, 3 deviations keep 99.9 % of its voxels).
pub const OUTLIER_DEVIATIONS: f64 = 3.0;

/// The least Otsu separability of the split below the volume's level that makes it the dark
/// level: one normal population split at its mean scores 2/pi (0.64), a uniform one 0.75, so
/// a split above 0.8 is between two populations, not inside the air's noise.
pub const SEPARATE_POPULATIONS: f64 = 0.8;

/// Share of the dark voxels on the faces below the top of the air ([`air_top`]).
pub const AIR_TOP_QUANTILE: f64 = 0.999;

/// Most of the volume's dark voxels (below the dark level) that lowering the face air's level
/// to a class's dim edge may open to classification: half the air check's allowance (5 %). A
/// skull-stripped brain's outer CSF opens 1.9-2.2 % (1.4-1.6 % of the face air); a leaky loop
/// whose rim keeps voxels of an 8-bit scan's air opens more than 9 % of the face air (the
/// engine, the lobster: `scripts/real_scans.py`).
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
    /// Voxels of this region are background too (the face air, when the threshold lies below
    /// the face air's level).
    pub face_air: Option<Arc<FaceRegion>>,
    /// Training voxels dropped per class as air or dark outliers.
    pub dropped_per_class: Vec<usize>,
    /// A class was drawn in the air around the body.
    pub air_is_a_class: bool,
    /// That class's position: the air around the body (`face_air`) is that class by
    /// construction, and no voxel inside the body is (the lungs of a chest are not the air
    /// however dark a window makes them).
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
    let level = dark_level(volume, training, &values);
    let dark: Vec<usize> = training
        .classes
        .iter()
        .zip(&values)
        .flat_map(|(class, values)| class.voxels.iter().zip(values).filter(|(_, v)| **v < level).map(|(&i, _)| i))
        .collect();
    if dark.is_empty() {
        // The common case: every lassoed voxel lies above the dark level.
        let lowest = values.iter().flatten().copied().fold(level, f64::min);
        let plan = BackgroundPlan {
            threshold: Some(lowest),
            dropped_per_class: vec![0; training.classes.len()],
            ..BackgroundPlan::default()
        };
        return (training.clone(), plan);
    }
    let mut in_face_air = reaches_face(volume, level, &dark);
    let mut dark_in_face = dark.into_iter().zip(in_face_air.drain(..)).collect::<Vec<_>>();
    dark_in_face.sort_unstable();
    let face_air = |voxel: usize| dark_in_face.binary_search(&(voxel, true)).is_ok();
    let face_flags: Vec<Vec<bool>> =
        training.classes.iter().map(|class| class.voxels.iter().map(|&v| face_air(v)).collect()).collect();
    let air_class = face_flags.iter().position(|flags| {
        let inside = flags.iter().filter(|&&f| f).count();
        !flags.is_empty() && inside as f64 >= AIR_CLASS_SHARE * flags.len() as f64
    });
    let air_is_a_class = air_class.is_some();

    let mut classes = Vec::with_capacity(training.classes.len());
    let mut dropped_per_class = Vec::with_capacity(training.classes.len());
    let mut lowest_kept = level;
    let mut lowest_kept_in_face_air = level;
    for ((class, values), flags) in training.classes.iter().zip(&values).zip(&face_flags) {
        let is_air_class = flags.iter().filter(|&&f| f).count() as f64 >= AIR_CLASS_SHARE * flags.len() as f64;
        let keep: Vec<bool> = if is_air_class {
            vec![true; values.len()]
        } else if air_is_a_class {
            // Another class is the air: this class's face air belongs to it.
            flags.iter().map(|&f| !f).collect()
        } else {
            let reference: Vec<f64> = values.iter().zip(flags).filter(|(_, f)| !**f).map(|(&v, _)| v).collect();
            let cutoff = low_outlier_cutoff(reference);
            values.iter().map(|&v| v >= level || v >= cutoff).collect()
        };
        // Kept dark voxels inside the body lower the threshold; kept ones in the face air (a
        // dim edge that continues the class) lower the face air's level.
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
        // The air around the body is the air class's, up to midway between the air's drawn
        // intensities and the darkest other class's brighter than it (a windowed CT's fat under
        // the skin lies below the dark level, joined to the air, and is not air), and at least
        // up to the top of the air as drawn.
        let median = |values: &[f64]| {
            let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
            (!finite.is_empty()).then(|| median_in_place(&mut finite))
        };
        let air_median = air_class.and_then(|position| median(&values[position]));
        // Classes as dark as the air (a windowed CT's lungs) are inside the body, not its edge.
        let darkest_other = (0..values.len())
            .filter(|&position| Some(position) != air_class)
            .filter_map(|position| median(&values[position]))
            .filter(|&other| air_median.is_some_and(|air| other > air))
            .fold(f64::INFINITY, f64::min);
        let air_level = match air_median {
            Some(air) if darkest_other.is_finite() && air < darkest_other => {
                // Never below the top of the air as drawn: an MRI's noisy air reaches far above
                // its median.
                let top = air_class.map_or(f64::NEG_INFINITY, |position| drawn_top(&values[position]));
                level.min(((air + darkest_other) / 2.0).max(top))
            }
            _ => level,
        };
        let face_air = Some(Arc::new(FaceRegion::find(volume, air_level)));
        // Inside the body, voxels darker than every other class's kept voxels are background,
        // as without an air class; below that nothing is evaluated, and the air around the
        // body (most of a scan's voxels) costs the classifier nothing.
        let lowest_other = cleaned
            .classes
            .iter()
            .enumerate()
            .filter(|&(position, _)| Some(position) != air_class)
            .flat_map(|(_, class)| class.voxels.iter().map(|&voxel| volume.value(voxel)))
            .filter(|value| value.is_finite())
            .fold(f64::INFINITY, f64::min);
        let threshold = lowest_other.is_finite().then_some(lowest_other.min(air_level));
        BackgroundPlan { threshold, face_air, dropped_per_class, air_is_a_class, air_class }
    } else {
        // A class reaches into the dark inside the body: everything is classified down to its
        // darkest voxel, except the face air (below its own level, lowered to a class's dim
        // edge in it).
        let face_level = lowered_face_level(volume, level, lowest_kept_in_face_air);
        let threshold = lowest_kept.min(face_level);
        let face_air = (threshold < face_level).then(|| Arc::new(FaceRegion::find(volume, face_level)));
        log::debug!("background: dark level {level}, face air below {face_level}, threshold {threshold}");
        BackgroundPlan { threshold: Some(threshold), face_air, dropped_per_class, air_is_a_class, air_class: None }
    };
    (cleaned, plan)
}

/// The volume's dark level: its Otsu threshold, unless that cuts through a lassoed tissue.
/// On a scan that is nearly all air with one small, very bright structure, Otsu splits the
/// bright structure off instead of the air: a tissue lies below the level, joins the faces
/// through the air, and would be taken for air drawn as a class. On an MRI whose faces cut the
/// head, a thin dark skull lies below Otsu's level and joins the faces where they cut it. So
/// when a class has at least [`AIR_CLASS_SHARE`] of its voxels in the face air, or its
/// lassos' core (the voxels past a finger's leak, `gate::lasso_core`) has its median below
/// Otsu's level (a finger's loop around a skull three voxels thick is half scalp and CSF, and
/// only its core tells what it was drawn around), the values below Otsu's threshold are split
/// again ([`level::split_below`]), and that split is the level when all of these hold:
/// * it separates two populations: Otsu's separability says so ([`SEPARATE_POPULATIONS`]), or
///   a class in the face air is unlike the air at the faces (its median above the dark face
///   voxels' [`upper_reach`]: a dark tissue joined to the air, such as a phantom's foam, whose
///   few voxels hardly move the histogram of a scan that is mostly air), not the air's own
///   noise. A core below the level alone needs the separability: otherwise an 8-bit scan's
///   dim rim between the air and the body (the Visible Male's, its core just below Otsu's
///   level) splits the air's own noise, and a class takes part of the face air. And that core
///   must lie above the split: a finger's loop around a CT's skull that is more than half air
///   has the air for its core (the cranium's), which would give a class the air around the
///   head (`docs/decisions/0008-background.md`);
/// * the air at the faces stays below it (at least half of the dark face voxels);
/// * no class is air by the same share at the new level (the class lies above it).
///
/// A loop drawn in the air fails the last test (its voxels are the air's), a scan cropped
/// inside the body (a dark tissue at the faces, no air) the first or the second.
fn dark_level(volume: &Volume, training: &TrainingSet, values: &[Vec<f64>]) -> f64 {
    let otsu = volume.otsu_threshold();
    let shares = air_shares(volume, training, values, otsu);
    // The classes drawn in the face air, by their medians; else the medians of the lassos'
    // cores below the level (without a voxel below it, a core cannot lie there).
    let in_face_air: Vec<f64> = shares
        .iter()
        .zip(values)
        .filter(|(share, _)| **share >= AIR_CLASS_SHARE)
        .map(|(_, values)| median_in_place(&mut values.clone()))
        .collect();
    let cores_below: Vec<f64> = if in_face_air.is_empty() {
        let reaching_below = training.classes.iter().zip(values).filter(|(_, values)| values.iter().any(|&v| v < otsu));
        reaching_below.filter_map(|(class, _)| core_median(volume, &class.voxels).filter(|&core| core < otsu)).collect()
    } else {
        Vec::new()
    };
    if in_face_air.is_empty() && cores_below.is_empty() {
        return otsu;
    }
    let Some(split) = level::split_below(volume, otsu) else { return otsu };
    // A core below the level must lie above the split: a loop more than half in the air has
    // the air for its core.
    if in_face_air.is_empty() && !cores_below.iter().any(|&core| core > split.level) {
        return otsu;
    }
    let face_dark: Vec<f64> = face_values(volume).into_iter().filter(|&v| v < otsu).collect();
    let face_air_top = upper_reach(face_dark.clone());
    let unlike_the_face_air = in_face_air.iter().any(|&median| face_air_top.is_some_and(|top| median > top));
    if split.separability < SEPARATE_POPULATIONS && !unlike_the_face_air {
        return otsu;
    }
    let face_below = face_dark.iter().filter(|&&v| v < split.level).count();
    if 2 * face_below < face_dark.len() {
        return otsu;
    }
    if air_shares(volume, training, values, split.level).into_iter().any(|share| share >= AIR_CLASS_SHARE) {
        return otsu;
    }
    split.level
}

/// The median of the finite values of a lasso's core (its voxels past a finger's leak,
/// [`super::gate::lasso_core`]); `None` when the core is too small to stand for the class.
fn core_median(volume: &Volume, voxels: &[usize]) -> Option<f64> {
    let core = super::gate::lasso_core(voxels, volume.dims);
    let mut values: Vec<f64> = core.iter().map(|&v| volume.value(v)).filter(|v| v.is_finite()).collect();
    (values.len() >= super::gate::MIN_CORE_VOXELS).then(|| median_in_place(&mut values))
}

/// For each class, the share of its voxels (`values` are theirs) in the face air below `level`.
fn air_shares(volume: &Volume, training: &TrainingSet, values: &[Vec<f64>], level: f64) -> Vec<f64> {
    let dark: Vec<usize> = training
        .classes
        .iter()
        .zip(values)
        .flat_map(|(class, values)| class.voxels.iter().zip(values).filter(|(_, v)| **v < level).map(|(&i, _)| i))
        .collect();
    let mut in_face_air: Vec<usize> =
        dark.iter().zip(reaches_face(volume, level, &dark)).filter(|(_, face)| *face).map(|(&i, _)| i).collect();
    in_face_air.sort_unstable();
    training
        .classes
        .iter()
        .map(|class| {
            let inside = class.voxels.iter().filter(|v| in_face_air.binary_search(v).is_ok()).count();
            if class.voxels.is_empty() { 0.0 } else { inside as f64 / class.voxels.len() as f64 }
        })
        .collect()
}

/// The top of the air on the volume's faces: the median of `face_dark` (the dark voxels on the
/// faces) plus [`OUTLIER_DEVIATIONS`] robust deviations (`1.4826 x` the median absolute
/// deviation); `None` when empty. A class whose median lies above it was drawn in a dark tissue
/// that joins the air (a low-density insert or foam at a body's edge, lungs the faces cut), not
/// in the air, whose voxels are the faces' own.
fn upper_reach(mut face_dark: Vec<f64>) -> Option<f64> {
    if face_dark.is_empty() {
        return None;
    }
    let median = median_in_place(&mut face_dark);
    let mut deviations: Vec<f64> = face_dark.iter().map(|&v| (v - median).abs()).collect();
    Some(median + OUTLIER_DEVIATIONS * (1.4826 * median_in_place(&mut deviations)))
}

/// The face air's level where a class's kept voxels reach below the dark `level` into it
/// (`lowest_kept`, their darkest): that voxel's value, not below the top of the air on the
/// faces ([`air_top`]); `level` itself when more than [`FACE_AIR_OPENED_SHARE`] of the
/// volume's dark voxels (below `level`) lie at or above the lowered level (then the kept voxels
/// are the air's own, not a dim edge of the class). The dark voxels stand in for the face air:
/// filling the face region costs a 256³ scan 140 ms, counting 15 ms.
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

/// The top of the air on the volume's faces where a class's dim edge joins it: the higher of
/// [`upper_reach`] and the [`AIR_TOP_QUANTILE`] of `face_dark` (the dark voxels on the faces;
/// the noise of MRI's air has a long tail); `None` when empty.
fn air_top(mut face_dark: Vec<f64>) -> Option<f64> {
    let reach = upper_reach(face_dark.clone())?;
    let rank = ((face_dark.len() - 1) as f64 * AIR_TOP_QUANTILE).round() as usize;
    Some(reach.max(*face_dark.select_nth_unstable_by(rank, f64::total_cmp).1))
}

/// The top of the air an air class drew: the [`AIR_CLASS_SHARE`] quantile of its values (the
/// share of them that lies in the air; the rest may be the body its loop touched); minus
/// infinity without one.
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

/// The value below which a voxel is a low outlier for `reference`: its median minus
/// [`OUTLIER_DEVIATIONS`] robust deviations of its lower half; minus infinity when empty.
fn low_outlier_cutoff(mut reference: Vec<f64>) -> f64 {
    if reference.is_empty() {
        return f64::NEG_INFINITY;
    }
    let median = median_in_place(&mut reference);
    let mut below: Vec<f64> = reference.iter().filter(|&&v| v <= median).map(|&v| median - v).collect();
    let deviation = 1.4826 * median_in_place(&mut below);
    median - OUTLIER_DEVIATIONS * deviation
}

/// The median (upper median for an even count) of a non-empty slice, reordering it.
pub(super) fn median_in_place(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let middle = values.len() / 2;
    *values.select_nth_unstable_by(middle, f64::total_cmp).1
}

/// Whether a plan with air as a class keeps every other class's training voxels above its
/// threshold (the air class is its region; nothing else it drew falls into the background).
#[cfg(test)]
fn keeps_every_other_class(volume: &Volume, cleaned: &TrainingSet, plan: &BackgroundPlan) -> bool {
    let Some(threshold) = plan.threshold else { return true };
    cleaned
        .classes
        .iter()
        .enumerate()
        .filter(|&(position, _)| Some(position) != plan.air_class)
        .all(|(_, class)| class.voxels.iter().all(|&voxel| volume.value(voxel) >= threshold))
}

#[cfg(test)]
mod situations;
#[cfg(test)]
mod tests;
