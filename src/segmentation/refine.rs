//! Whole-volume labelling, exact or coarse-to-fine (see the module doc of `segmentation`).
//!
//! Work is split into z slabs run in parallel; each slab reads its planes once, selects the
//! voxels to evaluate, computes only their features ([`FeatureSlabReader::compute_selected`]),
//! standardises them and hands the block to [`crate::classify::Model::predict_block`].

use super::{LabelVolume, Refinement, SegmentationError, Segmenter};
use crate::features::FeatureSlabReader;
use crate::volume::Volume;
use rayon::prelude::*;
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
        Refinement::CoarseToFine => Some(CoarseGrid::new(volume.dims)),
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
            || Worker::new(volume, segmenter),
            |worker, (slab, slab_labels)| -> Result<usize, SegmentationError> {
                let mut classified = 0;
                for (offset, plane_labels) in slab_labels.chunks_mut(plane).enumerate() {
                    if cancel.load(Ordering::Relaxed) {
                        return Err(SegmentationError::Cancelled);
                    }
                    let z = slab * slab_depth + offset;
                    volume.read_z_slice_f32(z, &mut worker.values);
                    worker.selected.clear();
                    let rows = worker.values.chunks_exact(size_x).zip(plane_labels.chunks_exact_mut(size_x));
                    for (y, (row_values, row_labels)) in rows.enumerate() {
                        for (x, (&value, label)) in row_values.iter().zip(row_labels.iter_mut()).enumerate() {
                            // NaN is never above the threshold: it is background.
                            if value.is_nan() || value < threshold {
                                *label = 0;
                                continue;
                            }
                            classified += 1;
                            let inherited = match &coarse {
                                None => None,
                                Some(grid) => grid.inherited_label(x, y, z, value, tolerance),
                            };
                            match inherited {
                                Some(class) => *label = class,
                                None => worker.selected.push(x + size_x * y),
                            }
                        }
                    }
                    evaluated.fetch_add(worker.selected.len(), Ordering::Relaxed);
                    worker.evaluate(z, plane_labels)?;
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

/// Per-thread buffers: the plane's values, the voxels selected in it, their features and
/// labels.
struct Worker<'a> {
    reader: FeatureSlabReader<'a>,
    segmenter: &'a Segmenter,
    values: Vec<f32>,
    selected: Vec<usize>,
    features: Vec<f32>,
    predicted: Vec<u8>,
}

impl<'a> Worker<'a> {
    fn new(volume: &'a Volume, segmenter: &'a Segmenter) -> Worker<'a> {
        Worker {
            reader: FeatureSlabReader::new(volume, segmenter.feature_set)
                .with_foreground_threshold(segmenter.summary.background_threshold.unwrap_or(f64::NEG_INFINITY) as f32),
            segmenter,
            values: vec![0.0; volume.dims[0] * volume.dims[1]],
            selected: Vec::new(),
            features: Vec::new(),
            predicted: Vec::new(),
        }
    }

    /// Classifies the `selected` voxels of plane `z` and writes their labels.
    fn evaluate(&mut self, z: usize, plane_labels: &mut [u8]) -> Result<(), SegmentationError> {
        if self.selected.is_empty() {
            return Ok(());
        }
        self.reader.compute_selected(z, &self.selected, &mut self.features)?;
        self.segmenter.standardiser.apply_in_place(&mut self.features)?;
        self.predicted.resize(self.selected.len(), 0);
        self.segmenter.classifier.predict_block(&self.features, &mut self.predicted)?;
        for (&index, &label) in self.selected.iter().zip(&self.predicted) {
            plane_labels[index] = label;
        }
        Ok(())
    }
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

    #[inline]
    fn index(&self, cx: usize, cy: usize, cz: usize) -> usize {
        cx + self.dims[0] * (cy + self.dims[1] * cz)
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
        let [size_x, _, _] = volume.dims;
        let coarse_plane = self.dims[0] * self.dims[1];
        let [coarse_x, coarse_y, _] = self.dims;
        // Neighbouring coarse planes on one worker share its feature reader's block.
        let planes_per_task = segmenter.feature_set.preferred_slab_depth(volume.dims).div_ceil(2);
        self.labels
            .par_chunks_mut(coarse_plane)
            .zip(self.values.par_chunks_mut(coarse_plane))
            .enumerate()
            .with_min_len(planes_per_task)
            .map_init(
                || Worker::new(volume, segmenter),
                |worker, (cz, (labels, values))| -> Result<(), SegmentationError> {
                    if cancel.load(Ordering::Relaxed) {
                        return Err(SegmentationError::Cancelled);
                    }
                    let z = 2 * cz;
                    volume.read_z_slice_f32(z, &mut worker.values);
                    worker.selected.clear();
                    for cy in 0..coarse_y {
                        for cx in 0..coarse_x {
                            let index = 2 * cx + size_x * 2 * cy;
                            let value = worker.values[index];
                            values[cx + coarse_x * cy] = value;
                            if value >= threshold {
                                worker.selected.push(index);
                            }
                        }
                    }
                    evaluated.fetch_add(worker.selected.len(), Ordering::Relaxed);
                    // Evaluate into a scratch plane, then keep the coarse voxels.
                    let mut plane_labels = vec![0u8; worker.values.len()];
                    worker.evaluate(z, &mut plane_labels)?;
                    for cy in 0..coarse_y {
                        for cx in 0..coarse_x {
                            labels[cx + coarse_x * cy] = plane_labels[2 * cx + size_x * 2 * cy];
                        }
                    }
                    tick(1);
                    Ok(())
                },
            )
            .collect::<Result<(), SegmentationError>>()
    }

    /// The label a fine voxel (itself above the background threshold) takes from its coarse
    /// neighbours, or `None` when it must be evaluated: its foreground neighbours disagree or
    /// there are none, or `value` lies outside their intensity range widened by `tolerance`.
    /// Background neighbours do not veto: at a surface the voxel's own intensity already says
    /// it is foreground, and a partial-volume voxel there falls outside the interior's range.
    #[inline]
    fn inherited_label(&self, x: usize, y: usize, z: usize, value: f32, tolerance: f32) -> Option<u8> {
        // An odd coordinate lies between two coarse voxels (one at the far border).
        let neighbours = |p: usize, coarse_size: usize| -> ([usize; 2], usize) {
            if p % 2 == 1 && p / 2 + 1 < coarse_size { ([p / 2, p / 2 + 1], 2) } else { ([p / 2, p / 2], 1) }
        };
        let (xs, nx) = neighbours(x, self.dims[0]);
        let (ys, ny) = neighbours(y, self.dims[1]);
        let (zs, nz) = neighbours(z, self.dims[2]);
        let mut common = None;
        let (mut low, mut high) = (f32::INFINITY, f32::NEG_INFINITY);
        for &cz in &zs[..nz] {
            for &cy in &ys[..ny] {
                for &cx in &xs[..nx] {
                    let index = self.index(cx, cy, cz);
                    let label = self.labels[index];
                    if label == 0 {
                        continue;
                    }
                    if common.is_some_and(|c| c != label) {
                        return None;
                    }
                    common = Some(label);
                    low = low.min(self.values[index]);
                    high = high.max(self.values[index]);
                }
            }
        }
        (value >= low - tolerance && value <= high + tolerance).then_some(common).flatten()
    }
}
