//! Where the classifier is unsure: each classified voxel's margin, the unsure voxels, and the
//! slice holding most of them, so the next lasso goes where it changes the most labels (users
//! miss regions the slices do not show: the paper's user survey, §4.1). A margin is how far the
//! vote was from going the other way: |f| of the winner's pair with the runner-up for an SVM
//! (|f| = 1 ends its margin band, snsvm.md §4), the winner's lead as a share of the trees for a
//! forest. [`survey`] finds the unsure voxels (`docs/method.md` §10).
//!
//! Never: changes labels, or decides what is shown.

use crate::classify;
use crate::classify::ClassSet;
use crate::features::features_of_voxels;
use crate::segmentation::{SegmentationError, Segmenter, TrainedClassifier};
use crate::slices::{Axis, SliceGeometry};
use crate::volume::Volume;

/// The most voxels [`survey`] evaluates: about 0.1 s of the default classifier on two cores.
pub const SURVEY_VOXELS: usize = 300_000;

/// The margin quantile that sets the unsure threshold: a doubtful classification marks at most
/// about this share of its voxels.
pub const UNSURE_SHARE: f64 = 0.1;

/// The unsure threshold's ceiling for an SVM: its margin band ends at |f| = 1.
pub const SVM_BOUNDARY: f32 = 1.0;

/// The unsure threshold's ceiling for a forest: a lead below this share of the trees is doubtful.
pub const FOREST_BOUNDARY: f32 = 0.5;

/// Voxels per block handed to the classifier.
const BLOCK_VOXELS: usize = 4096;

/// What [`survey`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct Survey {
    /// A voxel whose margin is below this is unsure.
    pub threshold: f32,
    /// Every `stride`-th voxel along each axis is evaluated.
    pub stride: usize,
    /// Classified voxels evaluated.
    pub evaluated: usize,
    /// Of those, the unsure ones.
    pub unsure: usize,
    /// Unsure voxels per axis (x, y, z) and plane index (only the grid's planes hold any).
    pub unsure_per_plane: [Vec<u32>; 3],
}

impl Survey {
    /// The plane along `axis` with the most unsure voxels (the first of equal ones) and their
    /// count; `None` when no voxel is unsure.
    pub fn most_unsure_slice(&self, axis: Axis) -> Option<(usize, u32)> {
        let counts = &self.unsure_per_plane[axis.position()];
        let (slice, &count) =
            counts.iter().enumerate().rev().max_by_key(|&(_, count)| *count).filter(|&(_, &count)| count > 0)?;
        Some((slice, count))
    }

    /// The unsure share of the evaluated voxels (0 when none was evaluated).
    pub fn unsure_fraction(&self) -> f64 {
        self.unsure as f64 / self.evaluated.max(1) as f64
    }
}

/// Margins of the raw rows of `features` (scratch) into `margins`; NaN for a non-finite value.
pub fn margins_block(
    segmenter: &Segmenter,
    features: &mut [f32],
    margins: &mut [f32],
) -> Result<(), SegmentationError> {
    match &segmenter.classifier {
        TrainedClassifier::SnSvm(model) => {
            segmenter.standardiser.apply_in_place(features)?;
            let pairs: Vec<(u8, u8)> = model.pairs().iter().map(|pair| (pair.first, pair.second)).collect();
            let mut values = vec![0f32; margins.len() * pairs.len()];
            model.decision_values_block(features, &mut values)?;
            pair_margins(model.class_ids(), &pairs, &values, None, margins);
        }
        TrainedClassifier::SnSvmPerPair(model) => {
            let allowed = model.allowed_sets(features, features.len() / margins.len().max(1));
            let pairs: Vec<(u8, u8)> = model.pairs.iter().map(|pair| pair.classes).collect();
            let mut values = vec![0f32; margins.len() * pairs.len()];
            model.pair_values_block(features, &allowed, &mut values)?;
            pair_margins(&model.class_ids, &pairs, &values, Some(&allowed), margins);
        }
        TrainedClassifier::Forest(forest) => {
            let classes = forest.class_ids().len();
            let mut votes = vec![0f32; margins.len() * classes];
            forest.votes_block(features, &mut votes)?;
            let trees = forest.tree_count().max(1) as f32;
            for (margin, votes) in margins.iter_mut().zip(votes.chunks_exact(classes)) {
                let (mut first, mut second) = (f32::MIN, f32::MIN);
                for &vote in votes {
                    if vote > first {
                        second = first;
                        first = vote;
                    } else if vote > second {
                        second = vote;
                    }
                }
                *margin = if classes < 2 { f32::INFINITY } else { (first - second) / trees };
            }
        }
    }
    Ok(())
}

/// One-vs-one margins: |f| of the pair of the vote's winner and runner-up. With `allowed` (a
/// class set per voxel, [`crate::segmentation::gate`]) only allowed classes take part; a voxel allowed one
/// class is sure (infinite), one allowed none is not classified (NaN).
fn pair_margins(
    class_ids: &[u8],
    pairs: &[(u8, u8)],
    values: &[f32],
    allowed: Option<&[ClassSet]>,
    margins: &mut [f32],
) {
    let classes = class_ids.len();
    let position = |id: u8| class_ids.iter().position(|&c| c == id).unwrap_or(0);
    let pair_positions: Vec<(usize, usize)> = pairs.iter().map(|&(a, b)| (position(a), position(b))).collect();
    let mut votes = vec![0u32; classes];
    let mut strength = vec![0f32; classes];
    for (voxel, (margin, values)) in margins.iter_mut().zip(values.chunks_exact(pairs.len().max(1))).enumerate() {
        let allowed = allowed.map_or(ClassSet::MAX, |sets| sets[voxel]);
        if allowed == 0 {
            *margin = f32::NAN;
            continue;
        }
        if allowed.count_ones() == 1 {
            *margin = f32::INFINITY;
            continue;
        }
        if let [f] = values {
            *margin = f.abs();
            continue;
        }
        if values.iter().any(|f| !f.is_finite()) {
            *margin = f32::NAN;
            continue;
        }
        classify::tally_votes_among(&pair_positions, values, allowed, &mut votes, &mut strength);
        let winner = classify::vote_winner(&votes, &strength);
        let runner_up = (0..classes)
            .filter(|&class| class != winner && classify::class_set_contains(allowed, class))
            .reduce(|best, class| if classify::ranks_above(&votes, &strength, class, best) { class } else { best })
            .unwrap_or(winner);
        let pair =
            pair_positions.iter().position(|&(a, b)| (a, b) == (winner, runner_up) || (b, a) == (winner, runner_up));
        *margin = pair.map_or(f32::INFINITY, |p| values[p].abs());
    }
}

/// The margins of `voxels` (volume indices), in blocks over the rayon pool.
pub fn voxel_margins(volume: &Volume, segmenter: &Segmenter, voxels: &[usize]) -> Result<Vec<f32>, SegmentationError> {
    use rayon::prelude::*;
    volume.check_still_mapped()?;
    let dim = segmenter.feature_set.dim();
    let blocks: Vec<Vec<f32>> = voxels
        .par_chunks(BLOCK_VOXELS)
        .map(|block| {
            let mut features = features_of_voxels(volume, segmenter.feature_set, block)?;
            let mut margins = vec![0f32; features.len() / dim.max(1)];
            margins_block(segmenter, &mut features, &mut margins)?;
            Ok(margins)
        })
        .collect::<Result<_, SegmentationError>>()?;
    Ok(blocks.concat())
}

/// Surveys the classified voxels of `labels` (0 background, x fastest) on a sparse grid of at
/// most [`SURVEY_VOXELS`]: unsure below the [`UNSURE_SHARE`] quantile of their margins, capped
/// at [`SVM_BOUNDARY`] or [`FOREST_BOUNDARY`]; counts the unsure voxels per plane.
pub fn survey(volume: &Volume, segmenter: &Segmenter, labels: &[u8]) -> Result<Survey, SegmentationError> {
    let volume = segmenter.scan(volume);
    let dims = volume.dims;
    let classified = labels.iter().filter(|&&label| label != 0).count();
    let stride = (1..).find(|&s: &usize| classified / (s * s * s) <= SURVEY_VOXELS).unwrap_or(1);
    let mut voxels = Vec::with_capacity(classified / (stride * stride * stride) + 1);
    for z in (stride / 2..dims[2]).step_by(stride) {
        for y in (stride / 2..dims[1]).step_by(stride) {
            let row = (z * dims[1] + y) * dims[0];
            voxels.extend(
                (stride / 2..dims[0])
                    .step_by(stride)
                    .map(|x| row + x)
                    .filter(|&v| labels.get(v).is_some_and(|&label| label != 0)),
            );
        }
    }
    let margins = voxel_margins(volume, segmenter, &voxels)?;
    let boundary = match segmenter.classifier {
        TrainedClassifier::Forest(_) => FOREST_BOUNDARY,
        _ => SVM_BOUNDARY,
    };
    let mut finite: Vec<f32> = margins.iter().copied().filter(|m| m.is_finite()).collect();
    let threshold = if finite.is_empty() {
        0.0
    } else {
        let at = ((finite.len() as f64 * UNSURE_SHARE) as usize).min(finite.len() - 1);
        let (_, quantile, _) = finite.select_nth_unstable_by(at, f32::total_cmp);
        quantile.min(boundary)
    };
    let mut unsure_per_plane = dims.map(|side| vec![0u32; side]);
    let mut unsure = 0;
    for (&voxel, &margin) in voxels.iter().zip(&margins) {
        if margin < threshold || margin.is_nan() {
            unsure += 1;
            let at = [voxel % dims[0], voxel / dims[0] % dims[1], voxel / (dims[0] * dims[1])];
            for (counts, &index) in unsure_per_plane.iter_mut().zip(&at) {
                counts[index] += 1;
            }
        }
    }
    Ok(Survey { threshold, stride, evaluated: voxels.len(), unsure, unsure_per_plane })
}

/// Unsure flags (margin below `threshold`, never background) per pixel of slice `slice` along
/// `axis`, row-major as [`SliceGeometry`]; `None` when the slice is outside the volume.
pub fn slice_unsure(
    volume: &Volume,
    segmenter: &Segmenter,
    labels: &[u8],
    threshold: f32,
    axis: Axis,
    slice: usize,
) -> Result<Option<Vec<bool>>, SegmentationError> {
    let volume = segmenter.scan(volume);
    let Some(geometry) = SliceGeometry::new(volume.dims, axis, slice) else { return Ok(None) };
    let pixels: Vec<(usize, usize)> = (0..geometry.height)
        .flat_map(|j| (0..geometry.width).map(move |i| (j * geometry.width + i, geometry.voxel_index(i, j))))
        .filter(|&(_, voxel)| labels.get(voxel).is_some_and(|&label| label != 0))
        .collect();
    let voxels: Vec<usize> = pixels.iter().map(|&(_, voxel)| voxel).collect();
    let margins = voxel_margins(volume, segmenter, &voxels)?;
    let mut unsure = vec![false; geometry.width * geometry.height];
    for (&(pixel, _), &margin) in pixels.iter().zip(&margins) {
        unsure[pixel] = margin < threshold || margin.is_nan();
    }
    Ok(Some(unsure))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::{demo_foot_with, lassos_inside};
    use crate::pipeline::{RunControl, classify_strokes};
    use crate::segmentation::SegmentationOptions;

    fn classified(options: &SegmentationOptions) -> (Volume, Segmenter, Vec<u8>) {
        let phantom = demo_foot_with([64, 48, 40], 11).unwrap();
        let strokes = lassos_inside(&phantom, &[1, 2], 3, 2.0);
        let result = classify_strokes(&phantom.volume, &strokes, options, None, RunControl::batch()).unwrap();
        (phantom.volume, result.segmenter, result.labels.labels)
    }

    #[test]
    fn unsure_voxels_are_few_and_lie_where_classes_meet() {
        for options in [SegmentationOptions::default(), SegmentationOptions::forest()] {
            // Against the classifier's own labels: the survey is the classifier's doubt, and
            // the coherence step after it moves borders by a voxel or two (the Potts sweeps).
            let options = SegmentationOptions { coherence: crate::segmentation::Coherence::None, ..options };
            let (volume, segmenter, labels) = classified(&options);
            let survey = survey(&volume, &segmenter, &labels).unwrap();
            assert!(survey.evaluated > 1000, "{survey:?}");
            assert!(survey.unsure > 0, "some voxel is unsure");
            assert!(survey.unsure_fraction() <= UNSURE_SHARE + 0.02, "{}", survey.unsure_fraction());
            // Unsure voxels are next to another class (or background) far more often than
            // classified voxels are on average (measured: 0.96-0.98 against 0.44).
            let dims = volume.dims;
            let near_border = |voxel: usize| {
                let [x, y, z] = [voxel % dims[0], voxel / dims[0] % dims[1], voxel / (dims[0] * dims[1])];
                (0..3).any(|axis| {
                    let at = [x, y, z];
                    [-1i64, 1].iter().any(|&d| {
                        let moved = at[axis] as i64 + d;
                        if moved < 0 || moved >= dims[axis] as i64 {
                            return false;
                        }
                        let mut other = at;
                        other[axis] = moved as usize;
                        labels[other[0] + dims[0] * (other[1] + dims[1] * other[2])] != labels[voxel]
                    })
                })
            };
            let classified: Vec<usize> = (0..labels.len()).filter(|&v| labels[v] != 0).collect();
            let margins = voxel_margins(&volume, &segmenter, &classified).unwrap();
            let unsure: Vec<usize> =
                classified.iter().zip(&margins).filter(|(_, m)| **m < survey.threshold).map(|(&v, _)| v).collect();
            let share = |voxels: &[usize]| {
                voxels.iter().filter(|&&v| near_border(v)).count() as f64 / voxels.len().max(1) as f64
            };
            assert!(
                share(&unsure) > share(&classified) + 0.3,
                "{:?}: unsure {:.2} near a border, all {:.2}",
                options.classifier_kind,
                share(&unsure),
                share(&classified)
            );
        }
    }

    #[test]
    fn the_most_unsure_slice_holds_the_most_unsure_voxels_of_its_axis() {
        let (volume, segmenter, labels) = classified(&SegmentationOptions::default());
        let survey = survey(&volume, &segmenter, &labels).unwrap();
        for axis in Axis::ALL {
            let (slice, count) = survey.most_unsure_slice(axis).unwrap();
            assert!(survey.unsure_per_plane[axis.position()].iter().all(|&c| c <= count));
            let flags = slice_unsure(&volume, &segmenter, &labels, survey.threshold, axis, slice).unwrap().unwrap();
            let on_slice = flags.iter().filter(|&&f| f).count();
            assert!(on_slice >= count as usize, "{axis}: {on_slice} unsure on the slice, {count} surveyed");
            let geometry = SliceGeometry::new(volume.dims, axis, slice).unwrap();
            for (pixel, _) in flags.iter().enumerate().filter(|(_, f)| **f) {
                let voxel = geometry.voxel_index(pixel % geometry.width, pixel / geometry.width);
                assert_ne!(labels[voxel], 0, "a background voxel is never unsure");
            }
        }
        assert!(slice_unsure(&volume, &segmenter, &labels, 1.0, Axis::Z, volume.dims[2]).unwrap().is_none());
    }

    #[test]
    fn multi_class_margins_are_the_winner_against_the_runner_up() {
        // Three classes, three pairs (1,2), (1,3), (2,3): class 1 wins both its duels; class 3
        // beats 2, so 3 is the runner-up and the margin is |f(1,3)|.
        let pairs = [(1, 2), (1, 3), (2, 3)];
        let mut margins = [0f32; 2];
        pair_margins(&[1, 2, 3], &pairs, &[0.9, 0.2, -0.5, f32::NAN, 0.1, 0.1], None, &mut margins);
        assert_eq!(margins[0], 0.2);
        assert!(margins[1].is_nan());
        pair_margins(&[1, 2], &[(1, 2)], &[-0.3, 0.7], None, &mut margins);
        assert_eq!(margins, [0.3, 0.7]);
    }

    #[test]
    fn the_gate_limits_the_winner_and_the_runner_up_to_the_allowed_classes() {
        let pairs = [(1, 2), (1, 3), (2, 3)];
        let values = [0.9, 0.2, -0.5, 0.9, 0.2, -0.5, 0.9, 0.2, -0.5, 0.9, 0.2, -0.5];
        let mut margins = [0f32; 4];
        // All allowed: 1 wins, 3 runs up (0.2). Classes 1 and 2 only: |f(1,2)| = 0.9. Class 3
        // only: sure. None (a non-finite intensity): not classified.
        pair_margins(&[1, 2, 3], &pairs, &values, Some(&[0b111, 0b011, 0b100, 0]), &mut margins);
        assert_eq!(margins[..3], [0.2, 0.9, f32::INFINITY]);
        assert!(margins[3].is_nan());
    }
}
