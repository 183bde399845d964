//! Whole-volume labelling, exact or coarse-to-fine (see the module doc of `segmentation`).
//!
//! Work is split into z slabs run in parallel; each slab reads its planes once (the feature
//! reader's plane buffers serve both the voxel selection and the features), selects the voxels
//! to evaluate, computes only their features ([`FeatureSlabReader::compute_selected`]),
//! standardises them and hands the block to [`crate::classify::Model::predict_block`].

use super::{LabelVolume, Refinement, SegmentationError, Segmenter};
use crate::features::FeatureSlabReader;
use crate::volume::Volume;
use rayon::prelude::*;
use std::ops::RangeInclusive;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A fine voxel copies its coarse neighbours' common label only when its intensity lies within
/// their range widened by this fraction of the training intensities' deviation; otherwise it
/// is evaluated (it may belong to a structure thinner than the coarse grid).
const INTENSITY_TOLERANCE: f64 = 0.05;

pub(super) fn label_volume(
    volume: &Volume,
    segmenter: &Segmenter,
    refinement: Refinement,
    progress: &(dyn Fn(f32) + Sync),
    cancel: &AtomicBool,
) -> Result<LabelVolume, SegmentationError> {
    let [size_x, size_y, size_z] = volume.dims;
    let plane = size_x * size_y;
    // z planes per parallel task: enough to amortise the feature reader's buffers (a rolling
    // plane buffer, or the multi-scale blocks' halo), few enough to balance the cores.
    let slab_depth = segmenter.feature_set.preferred_slab_depth(volume.dims);
    let threshold = segmenter.summary.background_threshold.unwrap_or(f64::NEG_INFINITY) as f32;
    let coarse = match refinement {
        Refinement::Exact => None,
        Refinement::CoarseToFine if segmenter.summary.used_per_class.len() <= RowNeighbours::MAX_CLASSES => {
            Some(CoarseGrid::new(volume.dims))
        }
        Refinement::CoarseToFine => None,
    };
    let steps = size_z + coarse.as_ref().map_or(0, |c| c.dims[2]);
    let done = AtomicUsize::new(0);
    let tick = |planes: usize| {
        let finished = done.fetch_add(planes, Ordering::Relaxed) + planes;
        progress(finished as f32 / steps.max(1) as f32);
    };
    let evaluated = AtomicUsize::new(0);

    let started = std::time::Instant::now();
    let coarse = match coarse {
        None => None,
        Some(mut grid) => {
            grid.classify(volume, segmenter, threshold, cancel, &tick, &evaluated)?;
            Some(grid)
        }
    };
    log::debug!("coarse pass: {} voxels evaluated in {:?}", evaluated.load(Ordering::Relaxed), started.elapsed());
    let started = std::time::Instant::now();
    let tolerance = (INTENSITY_TOLERANCE * segmenter.standardiser.std[0]) as f32;

    let mut labels = vec![0u8; volume.voxel_count()];
    let classified = labels
        .par_chunks_mut(plane * slab_depth)
        .enumerate()
        .map_init(
            || (Worker::new(volume, segmenter), RowNeighbours::default()),
            |(worker, row_neighbours), (slab, slab_labels)| -> Result<usize, SegmentationError> {
                let mut classified = 0;
                for (offset, plane_labels) in slab_labels.chunks_mut(plane).enumerate() {
                    if cancel.load(Ordering::Relaxed) {
                        return Err(SegmentationError::Cancelled);
                    }
                    let z = slab * slab_depth + offset;
                    let values = worker.reader.plane(z)?;
                    worker.selected.clear();
                    let rows = values.chunks_exact(size_x).zip(plane_labels.chunks_exact_mut(size_x));
                    for (y, (row_values, row_labels)) in rows.enumerate() {
                        // A vectorised test first: most rows of a scan are air.
                        if !any_at_or_above(row_values, threshold) {
                            continue;
                        }
                        let first = row_values.iter().position(|&value| value >= threshold).unwrap_or(0);
                        let last = row_values.iter().rposition(|&value| value >= threshold).unwrap_or(first);
                        let row = Row {
                            first,
                            first_index: first + size_x * y,
                            values: &row_values[first..=last],
                            labels: &mut row_labels[first..=last],
                        };
                        let (selected, foreground) = match &coarse {
                            Some(grid) => {
                                row_neighbours.summarise(grid, y, z, first / 2..=last / 2 + 1);
                                row_neighbours.label_row(row, threshold, tolerance, &mut worker.row_selected)
                            }
                            None => row.select_foreground(threshold, &mut worker.row_selected),
                        };
                        worker.selected.extend_from_slice(&worker.row_selected[..selected]);
                        classified += foreground;
                    }
                    evaluated.fetch_add(worker.selected.len(), Ordering::Relaxed);
                    worker.evaluate(z)?;
                    for (&index, &label) in worker.selected.iter().zip(&worker.predicted) {
                        plane_labels[index] = label;
                    }
                    tick(1);
                }
                Ok(classified)
            },
        )
        .collect::<Result<Vec<usize>, SegmentationError>>()?
        .into_iter()
        .sum();
    log::debug!(
        "labels: {} voxels evaluated in all, fine pass {:?}",
        evaluated.load(Ordering::Relaxed),
        started.elapsed()
    );
    Ok(LabelVolume {
        dims: volume.dims,
        labels,
        classified_voxels: classified,
        evaluated_voxels: evaluated.into_inner(),
    })
}

/// Whether any of `values` is at least `threshold`, in chunks the compiler vectorises.
fn any_at_or_above(values: &[f32], threshold: f32) -> bool {
    values.chunks(64).any(|chunk| chunk.iter().fold(false, |found, &value| found | (value >= threshold)))
}

/// Per-thread buffers: the feature reader (which also holds the plane values), the voxels
/// selected in a plane, their features and predicted labels.
struct Worker<'a> {
    reader: FeatureSlabReader<'a>,
    segmenter: &'a Segmenter,
    size_x: usize,
    selected: Vec<usize>,
    /// One row's selection before it joins `selected` (room for a whole row; a row fills a
    /// prefix).
    row_selected: Vec<usize>,
    features: Vec<f32>,
    predicted: Vec<u8>,
}

impl<'a> Worker<'a> {
    fn new(volume: &'a Volume, segmenter: &'a Segmenter) -> Worker<'a> {
        Worker {
            reader: FeatureSlabReader::new(volume, segmenter.feature_set)
                .with_foreground_threshold(segmenter.summary.background_threshold.unwrap_or(f64::NEG_INFINITY) as f32),
            segmenter,
            size_x: volume.dims[0],
            selected: Vec::new(),
            row_selected: vec![0; volume.dims[0]],
            features: Vec::new(),
            predicted: Vec::new(),
        }
    }

    /// Classifies the voxels of fine plane `z` (even) that lie on the coarse grid and above the
    /// threshold, into that coarse plane's `labels` (`coarse_size` x by y, zero on entry), and
    /// records their `values` (the only ones [`RowNeighbours::summarise`] reads).
    /// `coarse_indices` is scratch.
    fn classify_coarse_plane(
        &mut self,
        z: usize,
        coarse_size: [usize; 2],
        threshold: f32,
        coarse_indices: &mut Vec<usize>,
        labels: &mut [u8],
        values: &mut [f32],
    ) -> Result<(), SegmentationError> {
        let [coarse_x, coarse_y] = coarse_size;
        let size_x = self.size_x;
        let plane_values = self.reader.plane(z)?;
        self.selected.clear();
        coarse_indices.clear();
        for cy in 0..coarse_y {
            let row = &plane_values[size_x * 2 * cy..][..size_x];
            // Air rows stay as they are: label 0, and a background voxel's value is never read.
            if !any_at_or_above(row, threshold) {
                continue;
            }
            for cx in 0..coarse_x {
                let value = row[2 * cx];
                let coarse_index = cx + coarse_x * cy;
                values[coarse_index] = value;
                if value >= threshold {
                    self.selected.push(2 * cx + size_x * 2 * cy);
                    coarse_indices.push(coarse_index);
                }
            }
        }
        self.evaluate(z)?;
        for (&coarse_index, &label) in coarse_indices.iter().zip(&self.predicted) {
            labels[coarse_index] = label;
        }
        Ok(())
    }

    /// Classifies the `selected` voxels of plane `z` into `predicted` (same order).
    fn evaluate(&mut self, z: usize) -> Result<(), SegmentationError> {
        self.predicted.clear();
        if self.selected.is_empty() {
            return Ok(());
        }
        self.reader.compute_selected(z, &self.selected, &mut self.features)?;
        self.segmenter.standardiser.apply_in_place(&mut self.features)?;
        self.predicted.resize(self.selected.len(), 0);
        self.segmenter.classifier.predict_block(&self.features, &mut self.predicted)?;
        Ok(())
    }
}

/// The coarse coordinates next to fine coordinate `p` along an axis of `coarse_size` coarse
/// voxels: an odd coordinate lies between two, an even one (or an odd one at the far border)
/// on one, which the pair then holds twice.
#[inline]
fn coarse_neighbours(p: usize, coarse_size: usize) -> [usize; 2] {
    [p / 2, (p / 2 + p % 2).min(coarse_size - 1)]
}

/// The distinct coordinates of a [`coarse_neighbours`] pair.
fn distinct(pair: &[usize; 2]) -> &[usize] {
    if pair[0] == pair[1] { &pair[..1] } else { pair }
}

/// Labels and intensities of every second voxel along each axis (even coordinates).
struct CoarseGrid {
    dims: [usize; 3],
    labels: Vec<u8>,
    values: Vec<f32>,
}

impl CoarseGrid {
    fn new(fine: [usize; 3]) -> CoarseGrid {
        let dims = fine.map(|d| d.div_ceil(2));
        let count = dims.iter().product();
        CoarseGrid { dims, labels: vec![0; count], values: vec![0.0; count] }
    }

    /// Classifies every coarse voxel above the threshold.
    fn classify(
        &mut self,
        volume: &Volume,
        segmenter: &Segmenter,
        threshold: f32,
        cancel: &AtomicBool,
        tick: &(dyn Fn(usize) + Sync),
        evaluated: &AtomicUsize,
    ) -> Result<(), SegmentationError> {
        let coarse_plane = self.dims[0] * self.dims[1];
        let [coarse_x, coarse_y, _] = self.dims;
        // A task's coarse planes are the even planes of one slab (the multi-scale reader's
        // block, whose depth is even), so that no block is smoothed by two tasks.
        let planes_per_task = segmenter.feature_set.preferred_slab_depth(volume.dims).div_ceil(2);
        self.labels
            .par_chunks_mut(coarse_plane * planes_per_task)
            .zip(self.values.par_chunks_mut(coarse_plane * planes_per_task))
            .enumerate()
            .map_init(
                || (Worker::new(volume, segmenter), Vec::new()),
                |(worker, coarse_indices), (task, (task_labels, task_values))| -> Result<(), SegmentationError> {
                    let planes = task_labels.chunks_mut(coarse_plane).zip(task_values.chunks_mut(coarse_plane));
                    for (offset, (labels, values)) in planes.enumerate() {
                        worker.classify_coarse_plane(
                            2 * (task * planes_per_task + offset),
                            [coarse_x, coarse_y],
                            threshold,
                            coarse_indices,
                            labels,
                            values,
                        )?;
                        evaluated.fetch_add(worker.selected.len(), Ordering::Relaxed);
                        tick(1);
                        if cancel.load(Ordering::Relaxed) {
                            return Err(SegmentationError::Cancelled);
                        }
                    }
                    Ok(())
                },
            )
            .collect::<Result<(), SegmentationError>>()
    }
}

/// What the coarse voxels around one fine row say, per coarse column: which classes the
/// foreground coarse voxels in the (up to four) coarse rows next to the fine row have (a bit
/// per class), and their intensity range. Summarising a row once makes each fine voxel's test
/// two lookups; the summary is branch-free so that it vectorises.
#[derive(Default)]
struct RowNeighbours {
    classes: Vec<u32>,
    low: Vec<f32>,
    high: Vec<f32>,
    coarse_size_x: usize,
}

impl RowNeighbours {
    /// Classes a bit set can hold: class k is bit k - 1 of a `u32`. With more classes the
    /// volume is labelled exactly.
    const MAX_CLASSES: usize = 31;

    /// Summarises the coarse rows next to fine row `y` of fine plane `z`, at coarse columns
    /// `columns` (clamped to the grid; the others keep stale values and must not be asked for).
    fn summarise(&mut self, grid: &CoarseGrid, y: usize, z: usize, columns: RangeInclusive<usize>) {
        let [coarse_x, coarse_y, coarse_z] = grid.dims;
        self.coarse_size_x = coarse_x;
        self.classes.resize(coarse_x, 0);
        self.low.resize(coarse_x, f32::INFINITY);
        self.high.resize(coarse_x, f32::NEG_INFINITY);
        let columns = *columns.start()..(*columns.end() + 1).min(coarse_x);
        let classes = &mut self.classes[columns.clone()];
        let low = &mut self.low[columns.clone()];
        let high = &mut self.high[columns.clone()];
        classes.fill(0);
        low.fill(f32::INFINITY);
        high.fill(f32::NEG_INFINITY);
        let (ys, zs) = (coarse_neighbours(y, coarse_y), coarse_neighbours(z, coarse_z));
        for &cz in distinct(&zs) {
            for &cy in distinct(&ys) {
                let start = coarse_x * (cy + coarse_y * cz);
                let row_labels = &grid.labels[start + columns.start..start + columns.end];
                let row_values = &grid.values[start + columns.start..start + columns.end];
                let summary = classes.iter_mut().zip(low.iter_mut()).zip(high.iter_mut());
                for (((classes, low), high), (&label, &value)) in summary.zip(row_labels.iter().zip(row_values)) {
                    // Label 0 (background) sets no bit and leaves the range alone.
                    *classes |= 1u32.wrapping_shl(u32::from(label)) >> 1;
                    let foreground = label != 0;
                    *low = low.min(if foreground { value } else { f32::INFINITY });
                    *high = high.max(if foreground { value } else { f32::NEG_INFINITY });
                }
            }
        }
    }

    /// Labels the foreground voxels of `row` that take a label from their coarse neighbours
    /// and writes the plane indices of the others, which must be evaluated, to the front of
    /// `selected` (at least as long as the row). Returns how many it wrote and how many
    /// voxels were foreground. A voxel inherits when its foreground coarse neighbours agree
    /// on one class and its intensity lies within theirs widened by `tolerance`. Background
    /// neighbours do not veto: at a surface the voxel's own intensity already says it is
    /// foreground, and a partial-volume voxel there falls outside the interior's range.
    /// Branch-free per voxel: at boundaries the outcomes alternate unpredictably.
    fn label_row(&self, row: Row, threshold: f32, tolerance: f32, selected: &mut [usize]) -> (usize, usize) {
        let (first, first_index) = (row.first, row.first_index);
        let (mut count, mut foreground_count) = (0, 0);
        for (offset, values, labels) in row.chunks_with_foreground(threshold) {
            for (k, (&value, label)) in values.iter().zip(labels.iter_mut()).enumerate() {
                let x = first + offset + k;
                let [left, right] = coarse_neighbours(x, self.coarse_size_x);
                let classes = self.classes[left] | self.classes[right];
                let low = self.low[left].min(self.low[right]) - tolerance;
                let high = self.high[left].max(self.high[right]) + tolerance;
                // NaN is never above the threshold: it is background.
                let foreground = value >= threshold;
                let inherits = classes.is_power_of_two() & (value >= low) & (value <= high);
                *label = if foreground & inherits { classes.trailing_zeros() as u8 + 1 } else { 0 };
                selected[count] = first_index + offset + k;
                count += usize::from(foreground & !inherits);
                foreground_count += usize::from(foreground);
            }
        }
        (count, foreground_count)
    }
}

/// A span of one fine row: its voxels' values and labels from column `first` on, and the
/// plane index of that first voxel.
struct Row<'a> {
    first: usize,
    first_index: usize,
    values: &'a [f32],
    labels: &'a mut [u8],
}

impl<'a> Row<'a> {
    /// Voxels per chunk that [`Row::chunks_with_foreground`] tests at once.
    const CHUNK: usize = 32;

    /// The row's chunks that hold a foreground voxel, with their offset in the row: runs of
    /// air inside the span (between the parts of an object, or noise above the threshold
    /// scattered through the air) are skipped a vectorised test at a time.
    fn chunks_with_foreground(self, threshold: f32) -> impl Iterator<Item = (usize, &'a [f32], &'a mut [u8])> {
        self.values
            .chunks(Self::CHUNK)
            .zip(self.labels.chunks_mut(Self::CHUNK))
            .enumerate()
            .filter(move |(_, (values, _))| any_at_or_above(values, threshold))
            .map(|(chunk, (values, labels))| (chunk * Self::CHUNK, values, labels))
    }

    /// Writes the plane indices of the foreground voxels to the front of `selected` (exact
    /// labelling: every one is evaluated); returns their count twice, as
    /// [`RowNeighbours::label_row`] does.
    fn select_foreground(self, threshold: f32, selected: &mut [usize]) -> (usize, usize) {
        let first_index = self.first_index;
        let mut count = 0;
        for (offset, values, _) in self.chunks_with_foreground(threshold) {
            for (k, &value) in values.iter().enumerate() {
                selected[count] = first_index + offset + k;
                count += usize::from(value >= threshold);
            }
        }
        (count, count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    impl RowNeighbours {
        /// The label fine voxel `x` of value `value` inherits, or `None` when it is evaluated.
        fn inherited_label(&self, x: usize, value: f32, tolerance: f32) -> Option<u8> {
            let (mut values, mut labels, mut selected) = ([value], [0u8], [usize::MAX]);
            let row = Row { first: x, first_index: x, values: &mut values, labels: &mut labels };
            match self.label_row(row, f32::NEG_INFINITY, tolerance, &mut selected) {
                (0, 1) => Some(labels[0]),
                (1, 1) if selected[0] == x => None,
                other => panic!("unexpected outcome {other:?}"),
            }
        }
    }

    /// A 2 x 1 x 1 coarse grid (fine 4 x 1 x 1, or 3 x 1 x 1 for a far border) with the given
    /// labels and values, summarised for fine row 0 of plane 0.
    fn summary(labels: [u8; 2], values: [f32; 2]) -> RowNeighbours {
        let grid = CoarseGrid { dims: [2, 1, 1], labels: labels.to_vec(), values: values.to_vec() };
        let mut row = RowNeighbours::default();
        row.summarise(&grid, 0, 0, 0..=1);
        row
    }

    #[test]
    fn a_fine_voxel_between_agreeing_neighbours_inherits_their_label() {
        let row = summary([2, 2], [10.0, 20.0]);
        assert_eq!(row.inherited_label(0, 10.0, 0.0), Some(2));
        assert_eq!(row.inherited_label(1, 15.0, 0.0), Some(2));
        assert_eq!(row.inherited_label(2, 20.5, 1.0), Some(2), "within the tolerance");
    }

    #[test]
    fn disagreement_or_an_intensity_outside_the_range_means_evaluate() {
        let row = summary([1, 2], [10.0, 20.0]);
        assert_eq!(row.inherited_label(1, 15.0, 0.0), None, "neighbours disagree");
        assert_eq!(row.inherited_label(0, 10.0, 0.0), Some(1), "an even voxel sees one neighbour");
        let row = summary([3, 3], [10.0, 20.0]);
        assert_eq!(row.inherited_label(1, 25.0, 1.0), None, "brighter than both");
        assert_eq!(row.inherited_label(1, 5.0, 1.0), None, "darker than both");
    }

    #[test]
    fn background_neighbours_neither_vote_nor_veto() {
        let row = summary([0, 4], [0.0, 20.0]);
        assert_eq!(row.inherited_label(1, 20.0, 0.0), Some(4));
        assert_eq!(row.inherited_label(0, 20.0, 0.0), None, "no foreground neighbour");
        let row = summary([0, 0], [0.0, 0.0]);
        assert_eq!(row.inherited_label(1, 0.0, 10.0), None);
    }

    #[test]
    fn the_highest_class_a_bit_set_holds_is_inherited() {
        let class = RowNeighbours::MAX_CLASSES as u8;
        let row = summary([class, class], [1.0, 1.0]);
        assert_eq!(row.inherited_label(1, 1.0, 0.0), Some(class));
    }

    #[test]
    fn rows_are_summarised_per_plane_and_row() {
        // Coarse 1 x 2 x 2: fine row 1 of plane 1 sits between all four coarse voxels.
        let grid = CoarseGrid { dims: [1, 2, 2], labels: vec![1, 1, 1, 2], values: vec![5.0; 4] };
        let mut row = RowNeighbours::default();
        row.summarise(&grid, 0, 0, 0..=0);
        assert_eq!(row.inherited_label(0, 5.0, 0.0), Some(1));
        row.summarise(&grid, 1, 1, 0..=0);
        assert_eq!(row.inherited_label(0, 5.0, 0.0), None);
        row.summarise(&grid, 2, 0, 0..=0);
        assert_eq!(row.inherited_label(0, 5.0, 0.0), Some(1), "the far border has one coarse row");
    }

    #[test]
    fn exact_rows_select_every_foreground_voxel_and_no_nan() {
        let values = [5.0, 1.0, f32::NAN, 7.0, 3.0];
        let mut labels = [9u8; 5];
        let mut selected = [0usize; 5];
        let row = Row { first: 2, first_index: 102, values: &values, labels: &mut labels };
        assert_eq!(row.select_foreground(3.0, &mut selected), (3, 3));
        assert_eq!(&selected[..3], &[102, 105, 106]);
    }

    #[test]
    fn any_at_or_above_finds_one_voxel_anywhere_and_ignores_nan() {
        let mut values = vec![0.0f32; 200];
        assert!(!any_at_or_above(&values, 1.0));
        values[137] = f32::NAN;
        assert!(!any_at_or_above(&values, 1.0));
        values[199] = 1.0;
        assert!(any_at_or_above(&values, 1.0));
    }
}
