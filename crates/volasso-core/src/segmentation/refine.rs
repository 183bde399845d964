//! Whole-volume labelling, exact or coarse-to-fine (`docs/decisions/0014-coarse-to-fine.md`).
//! Row foreground spans ([`ForegroundRows`]) let every pass skip air rows unread; parallel z
//! slabs compute only the selected voxels' features ([`FeatureSlabReader::compute_selected`]).
//! Coarse-to-fine labels the coarse grid, then the fine planes; with multi-scale features each
//! slab labels its own coarse planes, so no block is smoothed twice (the labels are the same).

use super::coarse_grid::{CoarseGrid, Row, RowNeighbours};
use super::{LabelVolume, Refinement, SegmentationError, Segmenter};
use crate::features::FeatureSlabReader;
use crate::volume::{ForegroundRows, Volume};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Widening of the coarse neighbours' intensity range, in training deviations, within which a
/// fine voxel copies their label; a voxel outside is evaluated, so a structure thinner than the
/// coarse grid is not lost (`docs/decisions/0014-coarse-to-fine.md`).
const INTENSITY_TOLERANCE: f64 = 0.05;

/// Which order coarse-to-fine labelling runs in (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Order {
    /// Every voxel above the threshold is evaluated.
    Exact,
    /// The whole coarse grid first, then the fine planes.
    TwoPasses,
    /// Coarse then fine planes slab by slab.
    OneSweep,
}

/// What every slab task shares.
struct Job<'a> {
    volume: &'a Volume,
    segmenter: &'a Segmenter,
    threshold: f32,
    /// The foreground span of every row at `threshold`: rows without one are skipped unread.
    rows: ForegroundRows,
    tolerance: f32,
    slab_depth: usize,
    cancel: &'a AtomicBool,
    progress: &'a (dyn Fn(f32) + Sync),
    /// Planes done (coarse and fine) and planes in all, for `progress`.
    done: AtomicUsize,
    steps: usize,
    evaluated: AtomicUsize,
}

impl Job<'_> {
    fn tick(&self) {
        let finished = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        (self.progress)((finished as f32 / self.steps.max(1) as f32).min(1.0));
    }

    fn check_cancel(&self) -> Result<(), SegmentationError> {
        if self.cancel.load(Ordering::Relaxed) { Err(SegmentationError::Cancelled) } else { Ok(()) }
    }

    /// Labels coarse planes `first..` with `worker`; those before `ticked_until` count as progress.
    #[allow(clippy::too_many_arguments)]
    fn classify_coarse_planes(
        &self,
        worker: &mut Worker,
        coarse_indices: &mut Vec<usize>,
        coarse_size: [usize; 2],
        first: usize,
        labels: &mut [u8],
        values: &mut [f32],
        ticked_until: usize,
    ) -> Result<(), SegmentationError> {
        let coarse_plane = coarse_size[0] * coarse_size[1];
        let planes = labels.chunks_mut(coarse_plane).zip(values.chunks_mut(coarse_plane));
        for (coarse_z, (labels, values)) in (first..).zip(planes) {
            self.check_cancel()?;
            worker.classify_coarse_plane(2 * coarse_z, coarse_size, self.threshold, coarse_indices, labels, values)?;
            self.evaluated.fetch_add(worker.selected.len(), Ordering::Relaxed);
            if coarse_z < ticked_until {
                self.tick();
            }
        }
        Ok(())
    }

    /// Labels a slab's fine planes from plane `first` on; returns the voxels above the threshold.
    fn label_fine_planes(
        &self,
        worker: &mut Worker,
        row_neighbours: &mut RowNeighbours,
        coarse: Option<&CoarseGrid>,
        first: usize,
        slab_labels: &mut [u8],
    ) -> Result<usize, SegmentationError> {
        let plane = self.volume.dims[0] * self.volume.dims[1];
        let mut classified = 0;
        for (offset, plane_labels) in slab_labels.chunks_mut(plane).enumerate() {
            self.check_cancel()?;
            let (foreground, evaluated) = worker.label_plane(
                first + offset,
                coarse,
                row_neighbours,
                self.threshold,
                self.tolerance,
                plane_labels,
            )?;
            classified += foreground;
            self.evaluated.fetch_add(evaluated, Ordering::Relaxed);
            self.tick();
        }
        Ok(classified)
    }
}

/// A coarse label volume's receiver (see `super::label_volume_with_preview`).
pub(super) type Preview<'a> = Option<&'a (dyn Fn(&LabelVolume) + Sync)>;

pub(super) fn label_volume(
    volume: &Volume,
    segmenter: &Segmenter,
    refinement: Refinement,
    progress: &(dyn Fn(f32) + Sync),
    cancel: &AtomicBool,
    preview: Preview,
) -> Result<LabelVolume, SegmentationError> {
    let order = match refinement {
        Refinement::CoarseToFine if segmenter.summary.used_per_class.len() <= RowNeighbours::MAX_CLASSES => {
            if segmenter.feature_set.scales().is_some() { Order::OneSweep } else { Order::TwoPasses }
        }
        Refinement::CoarseToFine | Refinement::Exact => Order::Exact,
    };
    // Planes per task: enough to amortise the reader's buffers, few to balance the cores; even.
    let slab_depth = segmenter.feature_set.preferred_slab_depth(volume.dims).next_multiple_of(2);
    label_volume_in(volume, segmenter, order, slab_depth, progress, cancel, preview)
}

fn label_volume_in(
    volume: &Volume,
    segmenter: &Segmenter,
    order: Order,
    slab_depth: usize,
    progress: &(dyn Fn(f32) + Sync),
    cancel: &AtomicBool,
    preview: Preview,
) -> Result<LabelVolume, SegmentationError> {
    let size_z = volume.dims[2];
    let threshold = segmenter.summary.background_threshold.unwrap_or(f64::NEG_INFINITY) as f32;
    let started = std::time::Instant::now();
    let job = Job {
        volume,
        segmenter,
        threshold,
        rows: if threshold == f32::NEG_INFINITY {
            ForegroundRows::every_voxel(volume.dims)
        } else {
            ForegroundRows::find(volume, threshold)
        },
        tolerance: (INTENSITY_TOLERANCE * segmenter.standardiser.std[0]) as f32,
        slab_depth,
        cancel,
        progress,
        done: AtomicUsize::new(0),
        steps: size_z + if order == Order::Exact { 0 } else { size_z.div_ceil(2) },
        evaluated: AtomicUsize::new(0),
    };
    log::debug!("foreground rows found in {:?}", started.elapsed());
    let mut labels = vec![0u8; volume.voxel_count()];
    let started = std::time::Instant::now();
    let classified = match order {
        Order::Exact => label_slabs(&job, None, &mut labels)?,
        Order::TwoPasses => {
            let mut grid = CoarseGrid::new(volume.dims);
            classify_coarse_grid(&job, &mut grid)?;
            log::debug!(
                "coarse pass: {} voxels evaluated in {:?}",
                job.evaluated.load(Ordering::Relaxed),
                started.elapsed()
            );
            if let Some(preview) = preview {
                preview(&coarse_preview(volume.dims, &grid, segmenter));
            }
            label_slabs(&job, Some(&grid), &mut labels)?
        }
        Order::OneSweep => label_slabs_in_one_sweep(&job, &mut labels)?,
    };
    log::debug!(
        "labels ({order:?}): {} voxels evaluated in all, {:?}",
        job.evaluated.load(Ordering::Relaxed),
        started.elapsed()
    );
    // Dark voxels inside the body stay classified; the air joined to the faces takes its label.
    let mut classified = classified.saturating_add_signed(paint_region(&mut labels, segmenter));
    if segmenter.coherence != super::Coherence::None {
        let started = std::time::Instant::now();
        let passes = super::coherence::DEFAULT_PASSES;
        let intensity = |voxel: usize| volume.value(voxel) as f32;
        let bands = super::coherence::LabelBands::new(
            (0..=u8::MAX).map(|label| segmenter.band(label).map(|band| (band.low, band.high))).collect(),
            &intensity,
        );
        let neighbourhood = super::coherence::Neighbourhood::for_spacing(volume.spacing_mm);
        let changed = super::coherence::majority_passes(&mut labels, volume.dims, passes, Some(&bands), neighbourhood);
        log::debug!("coherence: {changed} voxels took their neighbours' label ({:?})", started.elapsed());
        if segmenter.coherence == super::Coherence::Potts {
            let started = std::time::Instant::now();
            let changed = super::potts::potts_sweeps(volume, &mut labels, neighbourhood);
            log::debug!("coherence: {changed} voxels moved by the Potts sweeps ({:?})", started.elapsed());
        }
    }
    if segmenter.summary.region_label != 0 {
        // The air class is the air around the body whatever its neighbours' votes.
        classified = classified.saturating_add_signed(paint_region(&mut labels, segmenter));
    }
    for &(voxel, class) in &segmenter.lassoed {
        if let Some(label) = labels.get_mut(voxel) {
            classified += usize::from(*label == 0);
            *label = class;
        }
    }
    if segmenter.coherence == super::Coherence::Potts {
        let started = std::time::Instant::now();
        let changed = super::partial_volume::settle_layers(volume, &mut labels, &segmenter.lassoed);
        log::debug!("coherence: {changed} voxels of partial-volume layers moved ({:?})", started.elapsed());
        let started = std::time::Instant::now();
        let settled = super::undrawn::settle_undrawn(volume, &mut labels, &segmenter.lassoed);
        classified = classified.saturating_sub(settled.unlabelled);
        log::debug!(
            "coherence: {} voxels of undrawn tissues to another class, {} to none ({:?})",
            settled.relabelled,
            settled.unlabelled,
            started.elapsed()
        );
    }
    Ok(LabelVolume {
        dims: volume.dims,
        labels,
        classified_voxels: classified,
        evaluated_voxels: job.evaluated.into_inner(),
    })
}

/// The first look: each voxel takes the label of the coarse voxel at half its coordinates.
fn coarse_preview(dims: [usize; 3], grid: &CoarseGrid, segmenter: &Segmenter) -> LabelVolume {
    let plane = dims[0] * dims[1];
    let [coarse_x, coarse_y, _] = grid.dims;
    let mut labels = vec![0u8; dims[0] * dims[1] * dims[2]];
    labels.par_chunks_mut(plane.max(1)).enumerate().for_each(|(z, out)| {
        let coarse_plane = &grid.labels[(z / 2) * coarse_x * coarse_y..][..coarse_x * coarse_y];
        for (k, label) in out.iter_mut().enumerate() {
            let (x, y) = (k % dims[0], k / dims[0]);
            *label = coarse_plane[x / 2 + coarse_x * (y / 2)];
        }
    });
    paint_region(&mut labels, segmenter);
    let classified = labels.iter().filter(|&&label| label != 0).count();
    LabelVolume { dims, labels, classified_voxels: classified, evaluated_voxels: 0 }
}

/// Gives the voxels outside the body their label (0, or the class drawn in the air); returns
/// the change in classified voxels.
fn paint_region(labels: &mut [u8], segmenter: &Segmenter) -> isize {
    let Some(body) = &segmenter.summary.body else { return 0 };
    let region_label = segmenter.summary.region_label;
    let mut change = 0;
    for index in body.outside() {
        change += isize::from(region_label != 0) - isize::from(labels[index] != 0);
        labels[index] = region_label;
    }
    change
}

/// Labels every fine plane from `coarse` (`None`: exactly); returns the foreground count.
fn label_slabs(job: &Job, coarse: Option<&CoarseGrid>, labels: &mut [u8]) -> Result<usize, SegmentationError> {
    let plane = job.volume.dims[0] * job.volume.dims[1];
    let classified = labels
        .par_chunks_mut(plane * job.slab_depth)
        .enumerate()
        .map_init(
            || (Worker::new(job), RowNeighbours::default()),
            |(worker, row_neighbours), (slab, slab_labels)| {
                job.label_fine_planes(worker, row_neighbours, coarse, slab * job.slab_depth, slab_labels)
            },
        )
        .collect::<Result<Vec<usize>, SegmentationError>>()?;
    Ok(classified.into_iter().sum())
}

/// Labels the whole coarse grid, slab by slab in parallel.
fn classify_coarse_grid(job: &Job, grid: &mut CoarseGrid) -> Result<(), SegmentationError> {
    let coarse_plane = grid.plane_len();
    let [coarse_x, coarse_y, _] = grid.dims;
    let planes_per_task = job.slab_depth / 2;
    grid.labels
        .par_chunks_mut(coarse_plane * planes_per_task)
        .zip(grid.values.par_chunks_mut(coarse_plane * planes_per_task))
        .enumerate()
        .map_init(
            || (Worker::new(job), Vec::new()),
            |(worker, coarse_indices), (task, (task_labels, task_values))| -> Result<(), SegmentationError> {
                let first = task * planes_per_task;
                job.classify_coarse_planes(
                    worker,
                    coarse_indices,
                    [coarse_x, coarse_y],
                    first,
                    task_labels,
                    task_values,
                    usize::MAX,
                )
            },
        )
        .collect::<Result<(), SegmentationError>>()
}

/// Coarse-to-fine in one sweep: each slab labels its coarse planes and the next slab's first,
/// then its fine planes.
fn label_slabs_in_one_sweep(job: &Job, labels: &mut [u8]) -> Result<usize, SegmentationError> {
    let dims = job.volume.dims;
    let plane = dims[0] * dims[1];
    let coarse_planes = dims[2].div_ceil(2);
    let classified = labels
        .par_chunks_mut(plane * job.slab_depth)
        .enumerate()
        .map_init(
            || (Worker::new(job), RowNeighbours::default(), CoarseGrid::new([0; 3]), Vec::new()),
            |(worker, row_neighbours, grid, coarse_indices), (slab, slab_labels)| -> Result<usize, SegmentationError> {
                let first = slab * job.slab_depth;
                let end = first + slab_labels.len() / plane;
                // Coarse planes first / 2 to end / 2 (the next slab's first), within the volume.
                let held = first / 2..(end / 2 + 1).min(coarse_planes);
                let own = end.div_ceil(2);
                grid.hold(dims, held.clone());
                let coarse_size = [grid.dims[0], grid.dims[1]];
                // The next slab's plane is ticked there.
                let (labels, values) = (&mut grid.labels, &mut grid.values);
                job.classify_coarse_planes(worker, coarse_indices, coarse_size, held.start, labels, values, own)?;
                job.label_fine_planes(worker, row_neighbours, Some(grid), first, slab_labels)
            },
        )
        .collect::<Result<Vec<usize>, SegmentationError>>()?;
    Ok(classified.into_iter().sum())
}

/// Per-thread buffers: the feature reader, a plane's selected voxels, their features and labels.
struct Worker<'a> {
    reader: FeatureSlabReader<'a>,
    segmenter: &'a Segmenter,
    rows: &'a ForegroundRows,
    size_x: usize,
    selected: Vec<usize>,
    /// One row's selection before it joins `selected` (room for a whole row).
    row_selected: Vec<usize>,
    features: Vec<f32>,
    predicted: Vec<u8>,
    /// Whether [`Segmenter::class_by_intensity`] may decide a voxel (no non-finite values).
    intensity_decides: bool,
    /// The voxels the intensity left undecided: positions in `selected`, plane indices, labels.
    undecided: Vec<usize>,
    undecided_indices: Vec<usize>,
    undecided_predicted: Vec<u8>,
}

impl<'a> Worker<'a> {
    fn new(job: &'a Job) -> Worker<'a> {
        let (volume, segmenter) = (job.volume, job.segmenter);
        Worker {
            reader: FeatureSlabReader::new(volume, segmenter.feature_set).with_foreground_rows(&job.rows),
            segmenter,
            rows: &job.rows,
            size_x: volume.dims[0],
            selected: Vec::new(),
            row_selected: vec![0; volume.dims[0]],
            features: Vec::new(),
            predicted: Vec::new(),
            intensity_decides: volume.value_range().non_finite_voxels == 0,
            undecided: Vec::new(),
            undecided_indices: Vec::new(),
            undecided_predicted: Vec::new(),
        }
    }

    /// Classifies fine plane `z`'s (even) voxels on the coarse grid and above the threshold into
    /// the coarse plane's `labels` (zeroed), recording `values` for [`RowNeighbours::summarise`].
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
            // Air stays as it is: label 0, and a background voxel's value is never read.
            let Some(span) = self.rows.span(2 * cy, z) else {
                continue;
            };
            let row = &plane_values[size_x * 2 * cy..][..size_x];
            for cx in span.start().div_ceil(2)..=span.end() / 2 {
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

    /// Labels fine plane `z` into `plane_labels` (zeroed), evaluating only voxels whose coarse
    /// neighbours are not conclusive (every one without `coarse`); returns (foreground, evaluated).
    fn label_plane(
        &mut self,
        z: usize,
        coarse: Option<&CoarseGrid>,
        row_neighbours: &mut RowNeighbours,
        threshold: f32,
        tolerance: f32,
        plane_labels: &mut [u8],
    ) -> Result<(usize, usize), SegmentationError> {
        let size_x = self.size_x;
        let values = self.reader.plane(z)?;
        self.selected.clear();
        let mut classified = 0;
        let rows = values.chunks_exact(size_x).zip(plane_labels.chunks_exact_mut(size_x));
        for (y, (row_values, row_labels)) in rows.enumerate() {
            let Some(span) = self.rows.span(y, z) else {
                continue;
            };
            let (first, last) = span.into_inner();
            let row = Row {
                first,
                first_index: first + size_x * y,
                values: &row_values[first..=last],
                labels: &mut row_labels[first..=last],
            };
            let (selected, foreground) = match coarse {
                Some(grid) => {
                    row_neighbours.summarise(grid, y, z, first / 2..=last / 2 + 1, tolerance);
                    row_neighbours.label_row(row, threshold, &mut self.row_selected)
                }
                None => row.select_foreground(threshold, &mut self.row_selected),
            };
            self.selected.extend_from_slice(&self.row_selected[..selected]);
            classified += foreground;
        }
        self.evaluate(z)?;
        for (&index, &label) in self.selected.iter().zip(&self.predicted) {
            plane_labels[index] = label;
        }
        Ok((classified, self.selected.len()))
    }

    /// Classifies the `selected` voxels of plane `z` into `predicted` (same order).
    fn evaluate(&mut self, z: usize) -> Result<(), SegmentationError> {
        self.predicted.clear();
        if self.selected.is_empty() {
            return Ok(());
        }
        self.predicted.resize(self.selected.len(), 0);
        if !self.intensity_decides {
            self.reader.compute_selected(z, &self.selected, &mut self.features)?;
            self.segmenter.classify_block(&mut self.features, &mut self.predicted)?;
            return Ok(());
        }
        // Most voxels' intensity allows one class: only the others' features are computed.
        let values = self.reader.plane(z)?;
        self.undecided.clear();
        self.undecided_indices.clear();
        for (position, (&index, label)) in self.selected.iter().zip(&mut self.predicted).enumerate() {
            match self.segmenter.class_by_intensity(values[index]) {
                Some(class) => *label = class,
                None => {
                    self.undecided.push(position);
                    self.undecided_indices.push(index);
                }
            }
        }
        if self.undecided.is_empty() {
            return Ok(());
        }
        self.reader.compute_selected(z, &self.undecided_indices, &mut self.features)?;
        self.undecided_predicted.clear();
        self.undecided_predicted.resize(self.undecided.len(), 0);
        self.segmenter.classify_block(&mut self.features, &mut self.undecided_predicted)?;
        for (&position, &label) in self.undecided.iter().zip(&self.undecided_predicted) {
            self.predicted[position] = label;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
