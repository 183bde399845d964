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
use std::ops::Range;
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
                        // Most rows of a scan are air, and most of the rest is air too.
                        let Some(span) = worker.foreground_chunks.mark(row_values, threshold) else {
                            continue;
                        };
                        let row = Row {
                            first_index: size_x * y,
                            values: row_values,
                            labels: row_labels,
                            chunks: &worker.foreground_chunks,
                        };
                        let (selected, foreground) = match &coarse {
                            Some(grid) => {
                                row_neighbours.summarise(grid, y, z, span, tolerance);
                                row_neighbours.label_row(row, threshold, &mut worker.row_selected)
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
    /// Which chunks of the current row hold foreground.
    foreground_chunks: ForegroundChunks,
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
            foreground_chunks: ForegroundChunks::default(),
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

/// What the coarse voxels around one fine row say about each of its voxels: which classes its
/// foreground coarse neighbours have (a bit per class) and their intensity range, widened by
/// the tolerance. Built once per row (per coarse column over the up to four coarse rows next
/// to the fine row, then spread to the fine columns: an even column sits on one coarse
/// column, an odd one between two), so that labelling the row reads contiguous arrays
/// without an index computation per voxel. Branch-free, so that it vectorises.
#[derive(Default)]
struct RowNeighbours {
    /// Per coarse column (scratch for [`RowNeighbours::summarise`]).
    coarse: NeighbourSummary,
    /// Per fine column; current for the columns last summarised.
    fine: NeighbourSummary,
}

/// Class bit sets and intensity ranges, one entry per column.
#[derive(Default)]
struct NeighbourSummary {
    classes: Vec<u32>,
    low: Vec<f32>,
    high: Vec<f32>,
}

impl NeighbourSummary {
    fn resize(&mut self, columns: usize) {
        self.classes.resize(columns, 0);
        self.low.resize(columns, f32::INFINITY);
        self.high.resize(columns, f32::NEG_INFINITY);
    }
}

impl RowNeighbours {
    /// Classes a bit set can hold: class k is bit k - 1 of a `u32`. With more classes the
    /// volume is labelled exactly.
    const MAX_CLASSES: usize = 31;

    /// Summarises the coarse neighbours of fine row `y` of fine plane `z` for the fine
    /// columns `columns` (the others keep stale values and must not be asked for), with the
    /// intensity ranges widened by `tolerance`.
    fn summarise(&mut self, grid: &CoarseGrid, y: usize, z: usize, columns: Range<usize>, tolerance: f32) {
        let [coarse_x, coarse_y, coarse_z] = grid.dims;
        if columns.is_empty() {
            return;
        }
        // The coarse columns next to the fine ones: from the first's left neighbour to the
        // last's right one.
        let coarse_columns =
            coarse_neighbours(columns.start, coarse_x)[0]..coarse_neighbours(columns.end - 1, coarse_x)[1] + 1;
        self.coarse.resize(coarse_x);
        let classes = &mut self.coarse.classes[coarse_columns.clone()];
        let low = &mut self.coarse.low[coarse_columns.clone()];
        let high = &mut self.coarse.high[coarse_columns.clone()];
        classes.fill(0);
        low.fill(f32::INFINITY);
        high.fill(f32::NEG_INFINITY);
        let (ys, zs) = (coarse_neighbours(y, coarse_y), coarse_neighbours(z, coarse_z));
        for &cz in distinct(&zs) {
            for &cy in distinct(&ys) {
                let start = coarse_x * (cy + coarse_y * cz);
                let row_labels = &grid.labels[start + coarse_columns.start..start + coarse_columns.end];
                let row_values = &grid.values[start + coarse_columns.start..start + coarse_columns.end];
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
        self.fine.resize(columns.end.max(self.fine.classes.len()));
        let coarse = &self.coarse;
        let fine_columns = self.fine.classes[columns.clone()]
            .iter_mut()
            .zip(&mut self.fine.low[columns.clone()])
            .zip(&mut self.fine.high[columns.clone()]);
        for (x, ((classes, low), high)) in columns.clone().zip(fine_columns) {
            let [left, right] = coarse_neighbours(x, coarse_x);
            *classes = coarse.classes[left] | coarse.classes[right];
            *low = coarse.low[left].min(coarse.low[right]) - tolerance;
            *high = coarse.high[left].max(coarse.high[right]) + tolerance;
        }
    }

    /// Labels the foreground voxels of `row` that take a label from their coarse neighbours
    /// and writes the plane indices of the others, which must be evaluated, to the front of
    /// `selected` (at least as long as the row). Returns how many it wrote and how many
    /// voxels were foreground. A voxel inherits when its foreground coarse neighbours agree
    /// on one class and its intensity lies within their widened range (the row's summary,
    /// which must cover its foreground chunks). Background neighbours do not veto: at a
    /// surface the voxel's own intensity already says it is foreground, and a partial-volume
    /// voxel there falls outside the interior's range. Branch-free per voxel: at boundaries
    /// the outcomes alternate unpredictably.
    fn label_row(&self, row: Row, threshold: f32, selected: &mut [usize]) -> (usize, usize) {
        let first_index = row.first_index;
        let (mut count, mut foreground_count) = (0, 0);
        for (offset, values, labels) in row.chunks_with_foreground() {
            let columns = offset..offset + values.len();
            let summary = self.fine.classes[columns.clone()]
                .iter()
                .zip(&self.fine.low[columns.clone()])
                .zip(&self.fine.high[columns]);
            for (k, ((&value, label), ((&classes, &low), &high))) in
                values.iter().zip(labels.iter_mut()).zip(summary).enumerate()
            {
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

/// Which fixed-size chunks of a row hold a foreground voxel: one vectorised test per chunk,
/// so that the labelling loops visit only those (air surrounds an object and lies between
/// its parts; noise above the threshold can be scattered through it).
#[derive(Default)]
struct ForegroundChunks {
    flags: Vec<bool>,
}

impl ForegroundChunks {
    /// Voxels per chunk.
    const SIZE: usize = 32;

    /// Marks the chunks of `values` that hold a voxel at or above `threshold`; returns the
    /// columns from the first marked chunk's start to the last one's end, or `None` when no
    /// chunk is marked.
    fn mark(&mut self, values: &[f32], threshold: f32) -> Option<std::ops::Range<usize>> {
        self.flags.clear();
        self.flags.extend(values.chunks(Self::SIZE).map(|chunk| any_at_or_above(chunk, threshold)));
        let first = self.flags.iter().position(|&flag| flag)?;
        let last = self.flags.iter().rposition(|&flag| flag).unwrap_or(first);
        Some(first * Self::SIZE..((last + 1) * Self::SIZE).min(values.len()))
    }
}

/// One fine row: its voxels' values and labels, the plane index of its first voxel, and which
/// of its chunks hold foreground ([`ForegroundChunks::mark`] on these values).
struct Row<'a> {
    first_index: usize,
    values: &'a [f32],
    labels: &'a mut [u8],
    chunks: &'a ForegroundChunks,
}

impl<'a> Row<'a> {
    /// The row's chunks that hold a foreground voxel, with the column of their first voxel.
    fn chunks_with_foreground(self) -> impl Iterator<Item = (usize, &'a [f32], &'a mut [u8])> {
        let size = ForegroundChunks::SIZE;
        self.values
            .chunks(size)
            .zip(self.labels.chunks_mut(size))
            .zip(&self.chunks.flags)
            .enumerate()
            .filter(|(_, (_, flag))| **flag)
            .map(move |(chunk, ((values, labels), _))| (chunk * size, values, labels))
    }

    /// Writes the plane indices of the foreground voxels to the front of `selected` (exact
    /// labelling: every one is evaluated); returns their count twice, as
    /// [`RowNeighbours::label_row`] does.
    fn select_foreground(self, threshold: f32, selected: &mut [usize]) -> (usize, usize) {
        let first_index = self.first_index;
        let mut count = 0;
        for (offset, values, _) in self.chunks_with_foreground() {
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

    /// The label fine voxel `x` (of row `y`, plane `z`) of value `value` inherits from `grid`
    /// with intensity tolerance `tolerance`, or `None` when it is evaluated.
    fn inherited_label(grid: &CoarseGrid, [x, y, z]: [usize; 3], value: f32, tolerance: f32) -> Option<u8> {
        // NaN is background: only voxel x is foreground.
        let mut values = vec![f32::NAN; x + 1];
        values[x] = value;
        let (mut labels, mut selected) = (vec![0u8; x + 1], vec![usize::MAX; x + 1]);
        let mut chunks = ForegroundChunks::default();
        let span = chunks.mark(&values, f32::NEG_INFINITY)?;
        let mut neighbours = RowNeighbours::default();
        neighbours.summarise(grid, y, z, span, tolerance);
        let row = Row { first_index: 0, values: &values, labels: &mut labels, chunks: &chunks };
        match neighbours.label_row(row, f32::NEG_INFINITY, &mut selected) {
            (0, 1) => Some(labels[x]),
            (1, 1) if selected[0] == x => None,
            other => panic!("unexpected outcome {other:?}"),
        }
    }

    /// A 2 x 1 x 1 coarse grid (fine 4 x 1 x 1, or 3 x 1 x 1 for a far border) with the given
    /// labels and values.
    fn grid(labels: [u8; 2], values: [f32; 2]) -> CoarseGrid {
        CoarseGrid { dims: [2, 1, 1], labels: labels.to_vec(), values: values.to_vec() }
    }

    /// [`inherited_label`] of voxel `x` of fine row 0 of plane 0.
    fn inherited(grid: &CoarseGrid, x: usize, value: f32, tolerance: f32) -> Option<u8> {
        inherited_label(grid, [x, 0, 0], value, tolerance)
    }

    #[test]
    fn a_fine_voxel_between_agreeing_neighbours_inherits_their_label() {
        let grid = grid([2, 2], [10.0, 20.0]);
        assert_eq!(inherited(&grid, 0, 10.0, 0.0), Some(2));
        assert_eq!(inherited(&grid, 1, 15.0, 0.0), Some(2));
        assert_eq!(inherited(&grid, 2, 20.5, 1.0), Some(2), "within the tolerance");
        assert_eq!(inherited(&grid, 3, 20.0, 0.0), Some(2), "the far border has one coarse column");
    }

    #[test]
    fn disagreement_or_an_intensity_outside_the_range_means_evaluate() {
        let mixed = grid([1, 2], [10.0, 20.0]);
        assert_eq!(inherited(&mixed, 1, 15.0, 0.0), None, "neighbours disagree");
        assert_eq!(inherited(&mixed, 0, 10.0, 0.0), Some(1), "an even voxel sees one neighbour");
        assert_eq!(inherited(&mixed, 2, 20.0, 0.0), Some(2));
        let agreeing = grid([3, 3], [10.0, 20.0]);
        assert_eq!(inherited(&agreeing, 1, 25.0, 1.0), None, "brighter than both");
        assert_eq!(inherited(&agreeing, 1, 5.0, 1.0), None, "darker than both");
    }

    #[test]
    fn background_neighbours_neither_vote_nor_veto() {
        let half = grid([0, 4], [0.0, 20.0]);
        assert_eq!(inherited(&half, 1, 20.0, 0.0), Some(4));
        assert_eq!(inherited(&half, 0, 20.0, 0.0), None, "no foreground neighbour");
        let air = grid([0, 0], [0.0, 0.0]);
        assert_eq!(inherited(&air, 1, 0.0, 10.0), None);
    }

    #[test]
    fn the_highest_class_a_bit_set_holds_is_inherited() {
        let class = RowNeighbours::MAX_CLASSES as u8;
        assert_eq!(inherited(&grid([class, class], [1.0, 1.0]), 1, 1.0, 0.0), Some(class));
    }

    #[test]
    fn rows_are_summarised_per_plane_and_row() {
        // Coarse 1 x 2 x 2: fine row 1 of plane 1 sits between all four coarse voxels.
        let grid = CoarseGrid { dims: [1, 2, 2], labels: vec![1, 1, 1, 2], values: vec![5.0; 4] };
        assert_eq!(inherited_label(&grid, [0, 0, 0], 5.0, 0.0), Some(1));
        assert_eq!(inherited_label(&grid, [0, 1, 1], 5.0, 0.0), None);
        assert_eq!(inherited_label(&grid, [0, 2, 0], 5.0, 0.0), Some(1), "the far border has one coarse row");
    }

    #[test]
    fn a_summary_row_matches_the_per_voxel_rule() {
        // A long fine row (several chunks) over coarse columns with mixed labels: every
        // voxel's outcome is what its two coarse neighbours say.
        let coarse_x = 40;
        let labels: Vec<u8> = (0..coarse_x).map(|c| [1, 1, 2, 0, 2, 2, 2][c % 7]).collect();
        let values: Vec<f32> = (0..coarse_x).map(|c| (c % 5) as f32 * 10.0).collect();
        let grid = CoarseGrid { dims: [coarse_x, 1, 1], labels: labels.clone(), values: values.clone() };
        for x in 0..2 * coarse_x - 1 {
            let value = (x % 9) as f32 * 5.0;
            let [left, right] = coarse_neighbours(x, coarse_x);
            let foreground: Vec<usize> = distinct(&[left, right]).iter().copied().filter(|&c| labels[c] != 0).collect();
            let agree = !foreground.is_empty() && foreground.iter().all(|&c| labels[c] == labels[foreground[0]]);
            let low = foreground.iter().map(|&c| values[c]).fold(f32::INFINITY, f32::min) - 1.0;
            let high = foreground.iter().map(|&c| values[c]).fold(f32::NEG_INFINITY, f32::max) + 1.0;
            let expected = (agree && value >= low && value <= high).then(|| labels[foreground[0]]);
            assert_eq!(inherited(&grid, x, value, 1.0), expected, "fine column {x}");
        }
    }

    #[test]
    fn exact_rows_select_every_foreground_voxel_and_no_nan() {
        let values = [0.0, 0.0, 5.0, 1.0, f32::NAN, 7.0, 3.0];
        let mut labels = [9u8; 7];
        let mut selected = [0usize; 7];
        let mut chunks = ForegroundChunks::default();
        assert_eq!(chunks.mark(&values, 3.0), Some(0..7));
        let row = Row { first_index: 100, values: &values, labels: &mut labels, chunks: &chunks };
        assert_eq!(row.select_foreground(3.0, &mut selected), (3, 3));
        assert_eq!(&selected[..3], &[102, 105, 106]);
    }

    #[test]
    fn foreground_chunks_span_the_chunks_that_hold_foreground() {
        let mut values = vec![0.0f32; 100];
        let mut chunks = ForegroundChunks::default();
        assert_eq!(chunks.mark(&values, 1.0), None, "all air");
        values[40] = 2.0;
        values[97] = 1.0;
        assert_eq!(chunks.mark(&values, 1.0), Some(32..100), "the last chunk is short");
        assert_eq!(chunks.flags, [false, true, false, true]);
        let mut labels = vec![0u8; 100];
        let mut selected = vec![0usize; 100];
        let row = Row { first_index: 1000, values: &values, labels: &mut labels, chunks: &chunks };
        assert_eq!(row.select_foreground(1.0, &mut selected), (2, 2));
        assert_eq!(&selected[..2], &[1040, 1097]);
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
