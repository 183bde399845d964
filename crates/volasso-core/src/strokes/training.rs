//! Training voxels per class from a strokes file, and a stratified cap on their number.
//!
//! Within a class a voxel selected by several strokes counts once, for the first of them; a
//! stroke that repeats an earlier one exactly is not rasterised again, and loops on one slice
//! are merged run by run, so many copies of a loop cost nothing and many overlapping loops
//! cost their runs, not their voxels. A file whose loops would cross more than
//! [`MAX_ROW_CROSSINGS`] slice rows is refused before any is rasterised.
//! A voxel selected by two or more *classes* belongs to the one whose loop was drawn inside
//! the others' loops on its slice (a nucleus circled inside its cell: `super::nesting`).
//! Otherwise it is contested: it is dropped from all of them (counted in
//! [`TrainingSet::contested_voxels`] and logged as a warning), because a sample labelled twice
//! teaches the classifier nothing and would make its classes overlap. Neither rule depends on
//! the order of the classes.

use super::lasso::{polygon_rows, row_crossings};
use super::nesting;
use super::{Lasso, StrokesError, StrokesFile};
use crate::rng::{SplitMix64, hash64};
use crate::slices::SliceGeometry;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};

/// How a class's share of the training cap follows its size ([`TrainingSet::capped`]): a class
/// drawn at a sixteenth of the largest one's voxels keeps up to half as many. The SN-SVM weighs
/// its classes by their training voxels, so where classes overlap in features (a bone's
/// blurred edge, a joint space's partial volume) the larger class should keep the larger say:
/// with the same number of voxels for every class (exponent 0) a thin class the user drew with
/// a few hundred voxels claims the blurred edges of the structures around it (a knee's joint
/// space); in proportion to the drawn voxels (exponent 1) a small class loses its own blurred
/// edge to its surroundings (an aorta, cell nuclei and granules in a noisy MRI). Chosen on
/// `scripts/heldout.py`, whose loops the cap bites; the accuracy harness's stay under it
/// (`docs/decisions/0012-training-cap.md`).
pub const CAP_SIZE_EXPONENT: f64 = 0.25;

/// The (edge, row) crossings a strokes file's distinct lassos may cost to rasterise
/// ([`super::lasso::row_crossings`]). A hand-drawn loop crosses about twice as many rows as it
/// is tall, so a thousand loops across a 2048-row slice stay far below; a loop of a million
/// points that zig-zags across every row of a 512-row slice (5 x 10^8) is refused at once
/// instead of sorting its crossings for minutes. At the bound, rasterising takes about a second.
pub const MAX_ROW_CROSSINGS: u64 = 1 << 26;

/// The training voxels of one class.
#[derive(Clone, Debug, PartialEq)]
pub struct ClassSamples {
    /// The class's name, as in the strokes file.
    pub name: String,
    /// Volume indices (x fastest), sorted and unique.
    pub voxels: Vec<usize>,
    /// For each of `voxels`, the position in the class's strokes of the stroke it came from.
    pub stroke_of_voxel: Vec<u32>,
    /// Voxels kept from each stroke of the class (after contested voxels and any cap).
    pub stroke_voxel_counts: Vec<usize>,
    /// Voxels a cap ([`TrainingSet::capped`]) removed from this class.
    pub dropped_by_cap: usize,
}

/// Training voxels per class; class id k (1-based, the label the classifier uses) is
/// `classes[k - 1]`.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainingSet {
    /// Each class's samples, in the strokes file's order.
    pub classes: Vec<ClassSamples>,
    /// Voxels selected by more than one class, removed from all of them.
    pub contested_voxels: usize,
}

impl TrainingSet {
    /// The training voxels of `file` in a volume of `dims`. Checks the file against the volume,
    /// refuses a file without classes ([`StrokesError::NoClasses`]), a class whose lassos
    /// select nothing ([`StrokesError::EmptyClass`]) and one whose every voxel another class
    /// also selects ([`StrokesError::Overlapped`]).
    pub fn from_strokes(file: &StrokesFile, dims: [usize; 3]) -> Result<TrainingSet, StrokesError> {
        if file.classes.is_empty() {
            return Err(StrokesError::NoClasses);
        }
        let (set, overlapped_by) = TrainingSet::build(file, dims)?;
        if let Some((position, &Some(other))) = overlapped_by.iter().enumerate().find(|(_, by)| by.is_some()) {
            return Err(StrokesError::Overlapped {
                class: set.classes[position].name.clone(),
                class_id: position + 1,
                other: set.classes[other].name.clone(),
                other_id: other + 1,
            });
        }
        set.check_every_class_has_voxels()?;
        Ok(set)
    }

    /// As [`from_strokes`](Self::from_strokes), but a class may end up without voxels (a
    /// caller that builds the set while the user is still drawing).
    pub fn from_strokes_keeping_empty(file: &StrokesFile, dims: [usize; 3]) -> Result<TrainingSet, StrokesError> {
        TrainingSet::build(file, dims).map(|(set, _)| set)
    }

    /// The set, and for each class that only contested voxels emptied, the position of the
    /// first other class that selects one of them.
    fn build(file: &StrokesFile, dims: [usize; 3]) -> Result<(TrainingSet, Vec<Option<usize>>), StrokesError> {
        file.check_for_volume(dims)?;
        let distinct: Vec<Vec<usize>> = file.classes.iter().map(|class| distinct_strokes(&class.strokes)).collect();
        check_row_crossings(file, &distinct, dims)?;
        let mut classes: Vec<ClassSamples> = file
            .classes
            .iter()
            .zip(&distinct)
            .map(|(class, distinct)| {
                let (voxels, stroke_of_voxel) = class_voxels(&class.strokes, distinct, dims).into_iter().unzip();
                ClassSamples {
                    name: class.name.clone(),
                    voxels,
                    stroke_of_voxel,
                    stroke_voxel_counts: vec![0; class.strokes.len()],
                    dropped_by_cap: 0,
                }
            })
            .collect();
        let mut overlapped_by = vec![None; classes.len()];
        let shared = shared_voxels(&classes);
        let inner = nesting::inner_classes(file, dims, &shared);
        let contested_count = inner.iter().filter(|class| class.is_none()).count();
        if !shared.is_empty() {
            if contested_count > 0 {
                log::warn!(
                    "{contested_count} voxels are selected by more than one class; they are left out of training"
                );
            }
            if contested_count < shared.len() {
                log::info!(
                    "{} voxels lie in a loop drawn inside another class's loop: they are the inner class's",
                    shared.len() - contested_count
                );
            }
            let selected: Vec<Vec<usize>> = classes.iter().map(|c| c.voxels.clone()).collect();
            for (position, class) in classes.iter_mut().enumerate() {
                // A shared voxel stays with the class whose loop lies inside the others'.
                let keeps = |voxel: &usize| match shared.binary_search(voxel) {
                    Ok(k) => inner[k] == Some(position),
                    Err(_) => true,
                };
                let (voxels, strokes): (Vec<usize>, Vec<u32>) =
                    class.voxels.iter().zip(&class.stroke_of_voxel).filter(|(voxel, _)| keeps(voxel)).unzip();
                if voxels.is_empty() && !class.voxels.is_empty() {
                    let shares = |other: &Vec<usize>| class.voxels.iter().any(|v| other.binary_search(v).is_ok());
                    overlapped_by[position] =
                        selected.iter().enumerate().position(|(k, other)| k != position && shares(other));
                }
                class.voxels = voxels;
                class.stroke_of_voxel = strokes;
            }
        }
        for class in &mut classes {
            class.count_per_stroke();
        }
        Ok((TrainingSet { classes, contested_voxels: contested_count }, overlapped_by))
    }

    /// `Err(EmptyClass)` naming the first class without voxels.
    pub fn check_every_class_has_voxels(&self) -> Result<(), StrokesError> {
        match self.classes.iter().position(|c| c.voxels.is_empty()) {
            Some(position) => {
                Err(StrokesError::EmptyClass { class: self.classes[position].name.clone(), class_id: position + 1 })
            }
            None => Ok(()),
        }
    }

    /// Training voxels over all classes.
    pub fn voxel_count(&self) -> usize {
        self.classes.iter().map(|c| c.voxels.len()).sum()
    }

    /// The set with each class whose entry in `only` is `Some(voxels)` (sorted) reduced to its
    /// voxels that `voxels` holds; a class that would be left without any keeps all of its own.
    pub fn restricted(&self, only: &[Option<&[usize]>]) -> TrainingSet {
        let classes = self
            .classes
            .iter()
            .zip(only.iter().chain(std::iter::repeat(&None)))
            .map(|(class, only)| match only {
                Some(only) => {
                    let keep: Vec<bool> = class.voxels.iter().map(|voxel| only.binary_search(voxel).is_ok()).collect();
                    if keep.contains(&true) { class.retaining(&keep) } else { class.clone() }
                }
                None => class.clone(),
            })
            .collect();
        TrainingSet { classes, contested_voxels: self.contested_voxels }
    }

    /// Every training voxel with its class id (1-based), class by class.
    pub fn labelled_voxels(&self) -> (Vec<usize>, Vec<u8>) {
        let mut voxels = Vec::with_capacity(self.voxel_count());
        let mut labels = Vec::with_capacity(self.voxel_count());
        for (position, class) in self.classes.iter().enumerate() {
            voxels.extend_from_slice(&class.voxels);
            // from_strokes refuses more than 255 classes.
            labels.extend(std::iter::repeat_n((position + 1) as u8, class.voxels.len()));
        }
        (voxels, labels)
    }

    /// At most `max_per_class` voxels per class, drawn at random (seeded, so deterministic)
    /// and stratified over the class's strokes: each stroke keeps its share of the class,
    /// rounded by largest remainder. The largest class keeps up to `max_per_class`, and a
    /// class of n voxels keeps up to that times (n / the largest's count) to the power
    /// [`CAP_SIZE_EXPONENT`] (at least one voxel): the classes keep the order of the sizes the
    /// user drew them at. Classes already within their share are unchanged; `dropped_by_cap`
    /// says how many went.
    pub fn capped(&self, max_per_class: usize, seed: u64) -> TrainingSet {
        let largest = self.classes.iter().map(|class| class.voxels.len()).max().unwrap_or(0);
        let kept_by_largest = max_per_class.min(largest) as f64;
        let classes = self
            .classes
            .iter()
            .enumerate()
            .map(|(position, class)| {
                let count = class.voxels.len();
                let share = (count as f64 / largest.max(1) as f64).powf(CAP_SIZE_EXPONENT);
                let cap = ((kept_by_largest * share).round() as usize).max(count.min(1));
                class.capped(cap, hash64(seed, position as u64))
            })
            .collect();
        TrainingSet { classes, contested_voxels: self.contested_voxels }
    }
}

impl ClassSamples {
    /// A class named `name` of `voxels` (volume indices, sorted and unique), all from one
    /// stroke: scribbles painted into a label volume, or a box in a test.
    pub fn one_stroke(name: String, voxels: Vec<usize>) -> ClassSamples {
        ClassSamples {
            name,
            stroke_of_voxel: vec![0; voxels.len()],
            stroke_voxel_counts: vec![voxels.len()],
            voxels,
            dropped_by_cap: 0,
        }
    }

    fn count_per_stroke(&mut self) {
        self.stroke_voxel_counts.iter_mut().for_each(|c| *c = 0);
        for &stroke in &self.stroke_of_voxel {
            self.stroke_voxel_counts[stroke as usize] += 1;
        }
    }

    /// The class with only the voxels where `keep` (one flag per voxel) holds; the strokes'
    /// counts follow, the cap's count is kept.
    pub fn retaining(&self, keep: &[bool]) -> ClassSamples {
        let (voxels, stroke_of_voxel): (Vec<usize>, Vec<u32>) = self
            .voxels
            .iter()
            .zip(&self.stroke_of_voxel)
            .zip(keep)
            .filter(|(_, keep)| **keep)
            .map(|((&voxel, &stroke), _)| (voxel, stroke))
            .unzip();
        let mut retained = ClassSamples {
            name: self.name.clone(),
            voxels,
            stroke_of_voxel,
            stroke_voxel_counts: vec![0; self.stroke_voxel_counts.len()],
            dropped_by_cap: self.dropped_by_cap,
        };
        retained.count_per_stroke();
        retained
    }

    fn capped(&self, max_per_class: usize, seed: u64) -> ClassSamples {
        let total = self.voxels.len();
        if total <= max_per_class {
            return self.clone();
        }
        let quotas = largest_remainder_quotas(&self.stroke_voxel_counts, max_per_class);
        let mut rng = SplitMix64::new(seed);
        let mut kept: Vec<(usize, u32)> = Vec::with_capacity(max_per_class);
        // Each stroke's voxels in one pass (one pass per stroke cost strokes x voxels: minutes
        // for a file of 20,000 loops).
        let mut by_stroke: Vec<Vec<usize>> = vec![Vec::new(); quotas.len()];
        for (&voxel, &stroke) in self.voxels.iter().zip(&self.stroke_of_voxel) {
            by_stroke[stroke as usize].push(voxel);
        }
        for (stroke, (&quota, mut members)) in quotas.iter().zip(by_stroke).enumerate() {
            rng.partial_shuffle(&mut members, quota);
            kept.extend(members[..quota].iter().map(|&voxel| (voxel, stroke as u32)));
        }
        kept.sort_unstable();
        let (voxels, stroke_of_voxel): (Vec<usize>, Vec<u32>) = kept.into_iter().unzip();
        let mut capped = ClassSamples {
            name: self.name.clone(),
            dropped_by_cap: self.dropped_by_cap + total - voxels.len(),
            voxels,
            stroke_of_voxel,
            stroke_voxel_counts: self.stroke_voxel_counts.clone(),
        };
        capped.count_per_stroke();
        capped
    }
}

/// Splits `target` (< the sum of `counts`) in proportion to `counts`: floors first, then one
/// more to the largest fractional parts (ties to the earlier stroke).
fn largest_remainder_quotas(counts: &[usize], target: usize) -> Vec<usize> {
    let total: usize = counts.iter().sum();
    if total == 0 {
        return vec![0; counts.len()];
    }
    // Exact integer arithmetic: share = count * target / total.
    let mut quotas: Vec<usize> =
        counts.iter().map(|&c| ((c as u128 * target as u128) / total as u128) as usize).collect();
    let remainders: Vec<u128> = counts.iter().map(|&c| (c as u128 * target as u128) % total as u128).collect();
    let mut order: Vec<usize> = (0..counts.len()).collect();
    order.sort_by(|&a, &b| remainders[b].cmp(&remainders[a]).then(a.cmp(&b)));
    let missing = target.saturating_sub(quotas.iter().sum());
    for &stroke in order.iter().take(missing) {
        quotas[stroke] += 1;
    }
    quotas
}

/// The positions of `strokes` that are not exact repeats of an earlier stroke (same axis,
/// slice and points), in order: a repeat selects nothing its first copy did not, so it costs
/// nothing.
fn distinct_strokes(strokes: &[Lasso]) -> Vec<usize> {
    let key = |lasso: &Lasso| {
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        (lasso.axis.position(), lasso.slice).hash(&mut hasher);
        for point in &lasso.points {
            (point[0].to_bits(), point[1].to_bits()).hash(&mut hasher);
        }
        hasher.finish()
    };
    let same = |a: &Lasso, b: &Lasso| {
        a.axis == b.axis
            && a.slice == b.slice
            && a.points.len() == b.points.len()
            && a.points
                .iter()
                .zip(&b.points)
                .all(|(p, q)| p[0].to_bits() == q[0].to_bits() && p[1].to_bits() == q[1].to_bits())
    };
    let mut seen: HashMap<u64, Vec<usize>> = HashMap::new();
    let mut distinct = Vec::new();
    for (position, lasso) in strokes.iter().enumerate() {
        let earlier = seen.entry(key(lasso)).or_default();
        if !earlier.iter().any(|&k| same(&strokes[k], lasso)) {
            earlier.push(position);
            distinct.push(position);
        }
    }
    distinct
}

/// Refuses a file whose distinct lassos would cost more than [`MAX_ROW_CROSSINGS`] to
/// rasterise, naming the stroke that passes the bound.
fn check_row_crossings(file: &StrokesFile, distinct: &[Vec<usize>], dims: [usize; 3]) -> Result<(), StrokesError> {
    let mut crossings = 0u64;
    for (class, distinct) in file.classes.iter().zip(distinct) {
        for &stroke in distinct {
            let lasso = &class.strokes[stroke];
            let Some(geometry) = SliceGeometry::new(dims, lasso.axis, lasso.slice) else { continue };
            crossings = crossings.saturating_add(row_crossings(&lasso.points, geometry.height));
            if crossings > MAX_ROW_CROSSINGS {
                return Err(StrokesError::TooManyCrossings {
                    class: class.name.clone(),
                    stroke,
                    crossings,
                    limit: MAX_ROW_CROSSINGS,
                });
            }
        }
    }
    Ok(())
}

/// The voxels the strokes at positions `distinct` select, each once with the first stroke that
/// selects it, sorted by voxel. Loops on one slice are merged run by run (a run already taken
/// costs a lookup, not its length), so many overlapping loops cost their runs, and the memory
/// is the voxels selected.
fn class_voxels(strokes: &[Lasso], distinct: &[usize], dims: [usize; 3]) -> Vec<(usize, u32)> {
    let mut by_plane = distinct.to_vec();
    by_plane.sort_by_key(|&stroke| (strokes[stroke].axis.position(), strokes[stroke].slice, stroke));
    let mut tagged: Vec<(usize, u32)> = Vec::new();
    for plane in by_plane.chunk_by(|&a, &b| (strokes[a].axis, strokes[a].slice) == (strokes[b].axis, strokes[b].slice))
    {
        let first = &strokes[plane[0]];
        let Some(geometry) = SliceGeometry::new(dims, first.axis, first.slice) else { continue };
        // Per row, the runs taken so far: sorted, disjoint, not touching.
        let mut taken: HashMap<usize, Vec<(usize, usize)>> = HashMap::new();
        for &stroke in plane {
            polygon_rows(&strokes[stroke].points, geometry.width, geometry.height, |j, start, end| {
                take_run(taken.entry(j).or_default(), start, end, |from, to| {
                    tagged.extend(geometry.row_indices(j, from, to).map(|voxel| (voxel, stroke as u32)));
                });
            });
        }
    }
    // A voxel on slices of two axes: sorting by (voxel, stroke) and keeping the first of each
    // voxel gives it to its first stroke.
    tagged.sort_unstable();
    tagged.dedup_by_key(|&mut (voxel, _)| voxel);
    tagged
}

/// Adds the run `start..end` to `taken` (sorted, disjoint, not touching runs), calling `new`
/// with each part of it that was not taken before, left to right.
fn take_run(taken: &mut Vec<(usize, usize)>, start: usize, end: usize, mut new: impl FnMut(usize, usize)) {
    let first = taken.partition_point(|&(_, taken_end)| taken_end < start);
    let (mut cursor, mut merged) = (start, (start, end));
    let mut last = first;
    while last < taken.len() && taken[last].0 <= end {
        let (taken_start, taken_end) = taken[last];
        if taken_start > cursor {
            new(cursor, taken_start);
        }
        cursor = cursor.max(taken_end);
        merged = (merged.0.min(taken_start), merged.1.max(taken_end));
        last += 1;
    }
    if cursor < end {
        new(cursor, end);
    }
    taken.splice(first..last, [merged]);
}

/// Voxels that appear in more than one class, sorted.
fn shared_voxels(classes: &[ClassSamples]) -> Vec<usize> {
    let mut all: Vec<usize> = classes.iter().flat_map(|c| c.voxels.iter().copied()).collect();
    all.sort_unstable();
    // Each class's voxels are unique, so a repeat means two classes.
    let mut contested: Vec<usize> = all.windows(2).filter(|w| w[0] == w[1]).map(|w| w[0]).collect();
    contested.dedup();
    contested
}

#[cfg(test)]
#[path = "training_tests.rs"]
mod tests;
