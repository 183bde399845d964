//! The voxels a cleanly drawn loop encloses that are another class's: a loop around a cell
//! takes in its nucleus, a loop around an organ the vessels inside it (paper §3.2's lassos are
//! drawn around a structure, not along its inner boundaries).
//!
//! Such voxels are more than the band's trim ([`super::BAND_TRIM`]): they widen the class's band
//! over the other class's intensities, where the gate then gives the other class's voxels to
//! this class alone, and the classifier trains on them as this class. A voxel of the loop's
//! core ([`super::CORE_DEPTH`] inside its edge) is set aside as enclosed when its intensity is
//! at least as near another class's median intensity as its own class's, and its 3 x 3 x 3
//! mean lies within that class's core band and past [`ENCLOSED_REACH`] of the way from its own
//! class's median mean to that class's: the mean speaks for a structure several voxels across
//! rather than for noise, the intensity keeps in its class a voxel whose neighbours only mix
//! (a grey-matter voxel beside white matter). A cell's clean loop takes in a fifth of a
//! nucleus; set aside, those voxels no longer teach the cell
//! (`docs/decisions/0007-enclosed-voxels.md`).
//!
//! The voxels set aside still keep the class where they were lassoed (the user said what they
//! are; [`super::DrawnLassos::decided_voxels`]): a loop around a skull that takes in the brain
//! keeps its voxels, as the cranium's replay checks.
//!
//! Never: looks at a class whose rim leaked (its core alone stands for it then), one without a
//! core, or one whose median mean lies in the middle half of another class's core band (its
//! loop lies mostly over that class, as a finger's loop around a granule lies over the medium,
//! and which of its voxels are its own is not known).

use super::{BAND_TRIM, Band, DrawnClass, band_of, finite_values};
use crate::segmentation::background::median_in_place;
use crate::strokes::TrainingSet;
use crate::volume::Volume;

/// How far from its own class's median mean towards another class's a core voxel's 3 x 3 x 3
/// mean must lie to be set aside as enclosed (with its intensity nearer the other class).
/// Two thirds (a mean twice as near the other class's median as its own) sets aside too few of
/// a cell's nucleus; the intensity's test, not a farther reach, keeps grey matter beside white
/// matter in its class (`docs/decisions/0007-enclosed-voxels.md`).
pub const ENCLOSED_REACH: f64 = 1.0 / 3.0;

/// Sets aside, for each class that qualifies (module doc), the voxels its loops enclose of
/// another class: `classes[i].unenclosed` becomes its other voxels and their band where more
/// than [`BAND_TRIM`] of its voxels were enclosed. `classes` and `leaked` are in the class
/// order of `training`.
pub(super) fn set_aside(volume: &Volume, training: &TrainingSet, classes: &mut [DrawnClass], leaked: &[bool]) {
    let cores: Vec<Band> = classes.iter().map(|class| class.core).collect();
    let medians: Vec<f64> =
        training.classes.iter().map(|class| finite_median(finite_values(volume, &class.voxels))).collect();
    let median_means: Vec<f64> = training
        .classes
        .iter()
        .map(|class| finite_median(class.voxels.iter().map(|&voxel| local_mean(volume, voxel)).collect()))
        .collect();
    for (position, (class, drawn)) in classes.iter_mut().zip(&training.classes).enumerate() {
        let (own, own_mean) = (medians[position], median_means[position]);
        let over_another =
            cores.iter().enumerate().any(|(other, band)| other != position && in_middle_half(band, own_mean as f32));
        if leaked.get(position).copied().unwrap_or(true) || class.core_voxels.is_empty() || over_another {
            continue;
        }
        let enclosed_by = |other: usize, value: f64, mean: f64| {
            let reach = ENCLOSED_REACH * (median_means[other] - own_mean);
            other != position
                && reach != 0.0
                && cores[other].holds(mean as f32)
                && (value - medians[other]).abs() <= (value - own).abs()
                && (mean - own_mean) * reach.signum() > reach.abs()
        };
        let enclosed: Vec<usize> = class
            .core_voxels
            .iter()
            .copied()
            .filter(|&voxel| {
                let (value, mean) = (volume.value(voxel), local_mean(volume, voxel));
                (0..cores.len()).any(|other| enclosed_by(other, value, mean))
            })
            .collect();
        if enclosed.len() as f64 <= BAND_TRIM * drawn.voxels.len() as f64 {
            continue;
        }
        log::debug!(
            "class {}: {} of its {} lassoed voxels are another class's, enclosed by its loops",
            drawn.name,
            enclosed.len(),
            drawn.voxels.len()
        );
        // Both lists are sorted.
        let kept: Vec<usize> =
            drawn.voxels.iter().copied().filter(|voxel| enclosed.binary_search(voxel).is_err()).collect();
        if let Some(band) = band_of(&mut finite_values(volume, &kept)) {
            class.unenclosed = Some((kept, band));
        }
    }
}

/// Whether `value` lies in the middle half of `band`.
fn in_middle_half(band: &Band, value: f32) -> bool {
    (value - (band.low + band.high) / 2.0).abs() <= (band.high - band.low) / 4.0
}

/// The median of the finite `values`; NaN without any (every voxel beside a missing value:
/// nothing to compare with).
fn finite_median(mut values: Vec<f64>) -> f64 {
    values.retain(|value| value.is_finite());
    if values.is_empty() { f64::NAN } else { median_in_place(&mut values) }
}

/// The mean of `voxel`'s 3 x 3 x 3 neighbourhood (the part inside the volume).
fn local_mean(volume: &Volume, voxel: usize) -> f64 {
    let [size_x, size_y, size_z] = volume.dims;
    let plane = size_x * size_y;
    let (x, y, z) = (voxel % size_x, voxel / size_x % size_y, voxel / plane);
    let (mut sum, mut count) = (0.0, 0.0);
    for z in z.saturating_sub(1)..(z + 2).min(size_z) {
        for y in y.saturating_sub(1)..(y + 2).min(size_y) {
            for x in x.saturating_sub(1)..(x + 2).min(size_x) {
                sum += volume.value(z * plane + y * size_x + x);
                count += 1.0;
            }
        }
    }
    sum / count
}
