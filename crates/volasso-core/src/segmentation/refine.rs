//! Whole-volume labelling, exact or coarse-to-fine (see the module doc of `segmentation`).
//!
//! A first parallel pass finds the foreground span of every row ([`ForegroundRows`], on the
//! stored bytes of 8-bit scans): the passes after it skip air rows without reading them, and
//! the feature readers decode only the rows near foreground.
//!
//! Work is split into z slabs run in parallel; each slab reads its planes once (the feature
//! reader's plane buffers serve both the voxel selection and the features), selects the voxels
//! to evaluate, computes only their features ([`FeatureSlabReader::compute_selected`]),
//! standardises them and hands the block to [`crate::classify::Model::predict_block`].
//!
//! Coarse-to-fine runs in one of two orders. For the paper's features, a parallel pass labels
//! the whole coarse grid, then a second refines every plane. The multi-scale features smooth a
//! block of planes before they give any voxel's features, and two passes would smooth every
//! block twice; so there each slab labels its own coarse planes and the first of the next slab
//! (which that slab labels too: one coarse plane in about 15 twice), then refines its planes,
//! all from one smoothed block. Both orders give the same labels.

use super::coarse_grid::{CoarseGrid, Row, RowNeighbours};
use super::{LabelVolume, Refinement, SegmentationError, Segmenter};
use crate::features::FeatureSlabReader;
use crate::volume::{ForegroundRows, Volume};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A fine voxel copies its coarse neighbours' common label only when its intensity lies within
/// their range widened by this fraction of the training intensities' deviation; otherwise it
/// is evaluated (it may belong to a structure thinner than the coarse grid).
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

    /// Labels coarse planes `first..` (one per `coarse_size` chunk of `labels` and `values`)
    /// with `worker`, and counts those before `ticked_until` as progress.
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

    /// Labels the fine planes of a slab (`slab_labels`, from plane `first` on) with `worker`;
    /// returns the voxels above the threshold.
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
    // z planes per parallel task: enough to amortise the feature reader's buffers (a rolling
    // plane buffer, or the multi-scale blocks' halo), few enough to balance the cores. Even,
    // so that slabs hold whole pairs of planes.
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
    // Dark voxels inside the body are classified; the air joined to the faces is not: it is
    // background, or the class drawn in the air.
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
    Ok(LabelVolume {
        dims: volume.dims,
        labels,
        classified_voxels: classified,
        evaluated_voxels: job.evaluated.into_inner(),
    })
}

/// The coarse grid's labels copied to every voxel (each takes the label of the coarse voxel at
/// half its coordinates), the air joined to the faces left out.
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

/// Gives the voxels of the air joined to the faces (`background_region`) their label: 0, or the
/// class drawn in the air. Returns the change in classified voxels.
fn paint_region(labels: &mut [u8], segmenter: &Segmenter) -> isize {
    let Some(region) = &segmenter.summary.background_region else { return 0 };
    let region_label = segmenter.summary.region_label;
    let mut change = 0;
    for index in region.voxels.iter() {
        change += isize::from(region_label != 0) - isize::from(labels[index] != 0);
        labels[index] = region_label;
    }
    change
}

/// Labels every fine plane, slab by slab in parallel, from the whole volume's coarse grid
/// (`None`: exactly). Returns the voxels above the threshold.
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

/// Coarse-to-fine, slab by slab in parallel: each slab labels the coarse planes it needs (its
/// own and the next slab's first), then its fine planes (see the module doc).
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
                // Coarse planes next to the slab's fine planes: first / 2 up to end / 2 (the
                // next slab's first plane), clamped at the volume's last.
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

/// Per-thread buffers: the feature reader (which also holds the plane values), the voxels
/// selected in a plane, their features and predicted labels.
struct Worker<'a> {
    reader: FeatureSlabReader<'a>,
    segmenter: &'a Segmenter,
    rows: &'a ForegroundRows,
    size_x: usize,
    selected: Vec<usize>,
    /// One row's selection before it joins `selected` (room for a whole row; a row fills a
    /// prefix).
    row_selected: Vec<usize>,
    features: Vec<f32>,
    predicted: Vec<u8>,
    /// Whether the intensity alone may decide a voxel ([`Segmenter::class_by_intensity`]):
    /// every feature of a volume without non-finite values is finite.
    intensity_decides: bool,
    /// Positions in `selected` of the voxels the intensity left undecided, their plane indices,
    /// and their labels.
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

    /// Labels fine plane `z` into `plane_labels` (zero on entry): with a coarse grid holding
    /// the coarse planes next to `z`, evaluates only the voxels whose coarse neighbours are not
    /// conclusive; without one, every voxel above the threshold. Returns the voxels above the
    /// threshold and those evaluated.
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
            // Most rows of a scan are air.
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
