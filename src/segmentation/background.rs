//! The background: which voxels are air (label 0, never evaluated), and which lassoed voxels
//! are air that a finger took in rather than the class the user meant (paper §3.2's lassos as
//! they are drawn: a loop *around* a structure at the body's edge holds air too).
//!
//! Automatic rule ([`plan`]). The volume's dark level is its Otsu threshold
//! ([`Volume::otsu_threshold`], which splits air from everything else in CT and MRI alike);
//! the *face air* is the dark region joined to the volume's faces ([`super::face_air`]).
//! 1. A class with at least [`AIR_CLASS_SHARE`] of its voxels in the face air was drawn in the
//!    air: the user means air as a class. Other classes' face-air voxels are that class's.
//! 2. Otherwise each class is cleaned: its voxels outside the face air are its reference, and
//!    a dark voxel that is a low outlier for that reference (below its median by more than
//!    [`OUTLIER_DEVIATIONS`] robust deviations of its lower half, `1.4826 x` the median
//!    distance below the median) is dropped, inside the face air or not. Dark voxels that
//!    continue the class's own distribution stay (a scan cropped inside the body, where a dark
//!    tissue touches the faces; a lasso in the lungs).
//! 3. When air is a class, every voxel is classified. Otherwise the threshold is the dark
//!    level, lowered to the darkest kept voxel inside the body, so that no such training
//!    voxel falls into the background (a lasso in the lungs or the sinuses); the face air
//!    stays background all the same. Kept voxels in the face air (a rim of partial volume that
//!    continues a class) keep their class as lassoed voxels but do not open the air.
//!
//! Limitation: dark structures that the volume's faces cut (lungs in a chest cut through them)
//! are face air; a lasso in them is air drawn as a class, and every voxel is classified.
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

/// A class with at least this share of its voxels in the face air was drawn in the air: a
/// loop around a structure at the body's edge holds less (the structure is what it is drawn
/// around), a loop in the air touches the body with at most its rim.
pub const AIR_CLASS_SHARE: f64 = 0.9;

/// A dark training voxel more than this many robust deviations below its class's median is an
/// outlier for the class (for a normal class, 3 deviations keep 99.9 % of its voxels).
pub const OUTLIER_DEVIATIONS: f64 = 3.0;

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
    /// the dark level).
    pub face_air: Option<Arc<FaceRegion>>,
    /// Training voxels dropped per class as air or dark outliers.
    pub dropped_per_class: Vec<usize>,
    /// A class was drawn in the air around the body.
    pub air_is_a_class: bool,
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
    let level = volume.otsu_threshold();
    let values: Vec<Vec<f64>> =
        training.classes.iter().map(|class| class.voxels.iter().map(|&v| volume.value(v)).collect()).collect();
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
    let air_is_a_class = face_flags.iter().any(|flags| {
        let inside = flags.iter().filter(|&&f| f).count();
        !flags.is_empty() && inside as f64 >= AIR_CLASS_SHARE * flags.len() as f64
    });

    let mut classes = Vec::with_capacity(training.classes.len());
    let mut dropped_per_class = Vec::with_capacity(training.classes.len());
    let mut lowest_kept = level;
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
        // rim of partial volume that continues the class) keep their class as lassoed voxels
        // but do not open the air to classification.
        for ((&value, &kept), &in_face_air) in values.iter().zip(&keep).zip(flags) {
            if kept && !in_face_air {
                lowest_kept = lowest_kept.min(value);
            }
        }
        dropped_per_class.push(keep.iter().filter(|&&k| !k).count());
        classes.push(class.retaining(&keep));
    }
    let cleaned = TrainingSet { classes, contested_voxels: training.contested_voxels };
    let plan = if air_is_a_class {
        BackgroundPlan { threshold: None, face_air: None, dropped_per_class, air_is_a_class }
    } else {
        // A class reaches into the dark inside the body: everything is classified down to its
        // darkest voxel, except the face air.
        let face_air = (lowest_kept < level).then(|| Arc::new(FaceRegion::find(volume, level)));
        BackgroundPlan { threshold: Some(lowest_kept), face_air, dropped_per_class, air_is_a_class }
    };
    (cleaned, plan)
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
fn median_in_place(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let middle = values.len() / 2;
    *values.select_nth_unstable_by(middle, f64::total_cmp).1
}

#[cfg(test)]
mod tests;
