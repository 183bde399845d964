//! The voxels a clean loop encloses of another class (a cell's loop its nucleus, an organ's
//! its vessels): they would widen the class's band over the other class's intensities and
//! teach the class the other's voxels. A core voxel is set aside when its intensity is at least
//! as near another class's median as its own class's and its 3 x 3 x 3 mean lies in that
//! class's core band, past [`ENCLOSED_REACH`] of the way there (a grey-matter voxel beside
//! white matter stays). Set-aside voxels still keep the class where they were lassoed
//! (`docs/decisions/0007-enclosed-voxels.md`).
//!
//! Never: looks at a class whose rim leaked, one without a core, or one whose median mean lies
//! in the middle half of another class's core band (a loop mostly over that class). For a class
//! drawn on a structure too small for a core (a granule) that is the middle half of its values,
//! not of its band: the blur spreads its band over its neighbours' values.

use super::{BAND_TRIM, Band, DrawnClass, band_of, finite_values};
use crate::segmentation::background::finite_median;
use crate::segmentation::neighbours::cube_around;
use crate::strokes::TrainingSet;
use crate::volume::Volume;

/// How far from its own class's median mean towards another class's a core voxel's 3 x 3 x 3
/// mean must lie to be set aside; two thirds sets aside too little of a cell's nucleus
/// (`docs/decisions/0007-enclosed-voxels.md`).
pub const ENCLOSED_REACH: f64 = 1.0 / 3.0;

/// Sets aside, for each class that qualifies (module doc), the voxels its loops enclose of
/// another class: `classes[i].unenclosed` becomes its other voxels and their band where more
/// than [`BAND_TRIM`] of its voxels were enclosed. `classes` and `leaked` are in the class
/// order of `training`.
pub(super) fn set_aside(volume: &Volume, training: &TrainingSet, classes: &mut [DrawnClass], leaked: &[bool]) {
    let cores: Vec<Band> = classes.iter().map(|class| class.core).collect();
    // The quartiles of a class without a core (its core band is its whole, blurred band).
    let coreless_quartiles: Vec<Option<[f64; 3]>> =
        classes.iter().map(|class| class.core_voxels.is_empty().then_some(class.core_quartiles)).collect();
    // NaN without a finite value (every voxel beside a missing one): nothing to compare with.
    let medians: Vec<f64> = training
        .classes
        .iter()
        .map(|class| finite_median(finite_values(volume, &class.voxels)).unwrap_or(f64::NAN))
        .collect();
    let median_means: Vec<f64> = training
        .classes
        .iter()
        .map(|class| finite_median(class.voxels.iter().map(|&voxel| local_mean(volume, voxel))).unwrap_or(f64::NAN))
        .collect();
    for (position, (class, drawn)) in classes.iter_mut().zip(&training.classes).enumerate() {
        let (own, own_mean) = (medians[position], median_means[position]);
        let over_another = cores.iter().zip(&coreless_quartiles).enumerate().any(|(other, (band, quartiles))| {
            other != position
                && match quartiles {
                    Some([low, _, high]) => (*low..=*high).contains(&own_mean),
                    None => in_middle_half(band, own_mean as f32),
                }
        });
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

/// The mean of `voxel`'s 3 x 3 x 3 neighbourhood (the part inside the volume).
fn local_mean(volume: &Volume, voxel: usize) -> f64 {
    let (sum, count) =
        cube_around(voxel, volume.dims).fold((0.0, 0.0), |(sum, count), at| (sum + volume.value(at), count + 1.0));
    sum / count
}
