//! Undrawn tissues, the last of the spatial step. A class is what its loops drew. A finger's loop
//! round a small structure takes its partial volume with its neighbours, and a tissue nobody
//! drew can have those intensities: the grey matter has the values of a ventricle's blurred
//! border with the white matter, so the pair votes give it to the ventricle's class, a piece of
//! the class far from the ventricle and many times its size. Such a piece (6-connected voxels of
//! one class) touches none of its class's loops and holds more than [`SIZE_RATIO`] times the
//! voxels of all the pieces its loops touch together. When its median lies nearer the median of
//! another class's drawn pieces than its own class's, it goes to that class; when it holds more
//! than [`NO_CLASS_RATIO`] times their voxels and its median lies outside the middle half of its
//! own class's drawn values, no class drew it: it gets none (label 0), as the body's outside
//! does, rather than a class whose loops hold other intensities. When its median is its class's
//! own but more than [`MIXED_SHARE`] of its voxels lie outside the drawn pieces' range, it is
//! several tissues joined (the skull, the CSF round the brain and the cortex): those voxels get
//! none (`docs/decisions/0021-undrawn-tissues.md`).
//!
//! Never: changes a piece a loop touches, background (label 0), a piece as small as its class's
//! drawn ones (cells, lesions, calcifications: many pieces of one class, one of them drawn), one
//! whose intensity is its own class's (a second lung), or anything without loops (a learned
//! preset draws none); nor reads the classifier.

use super::background::median_in_place;
use super::gate::{BAND_TRIM, MIN_CORE_VOXELS, quantile, quartiles};
use super::neighbours::faces_of;
use crate::volume::Volume;
use std::collections::VecDeque;

/// A piece no loop touches is a candidate when it holds more than this many times the voxels of
/// all its class's drawn pieces: a cell, a lesion or a second lung is about as large as the
/// drawn one; the grey matter is ten to fifteen times a ventricle's drawn pieces.
pub const SIZE_RATIO: usize = 2;

/// A piece no loop touches gets no class when it holds more than this many times the voxels of
/// its class's drawn pieces and its median lies outside their middle half: a second lung is one
/// to three times the drawn one, the tissues nobody drew that `heldout.py`'s ventricle loops
/// took are 15 to 340 times their drawn pieces (5 gives the same tables).
pub const NO_CLASS_RATIO: usize = 10;

/// A piece far larger than its class's drawn ones ([`NO_CLASS_RATIO`]) whose median they drew
/// loses its voxels outside their range (their values less [`BAND_TRIM`] at each end) when more
/// than this share of it lies there: a piece of the drawn tissue alone has about twice
/// [`BAND_TRIM`] of its voxels there, its noise's tails, and keeps them.
pub const MIXED_SHARE: f64 = 0.1;

/// Intensities kept per class for its drawn median, at most (every k-th voxel reached).
const MEDIAN_SAMPLES: usize = 100_000;

/// What [`settle_undrawn`] changed, in voxels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Settled {
    /// Voxels that went to another class.
    pub relabelled: usize,
    /// Voxels that went to no class (label 0).
    pub unlabelled: usize,
}

/// Gives every undrawn tissue's piece (see the module doc) the class whose drawn pieces' median
/// is nearest its own, or no class, or no class to its voxels outside the drawn range;
/// `lassoed`: the voxels the user drew with their class ids.
///
/// The drawn pieces are found from the loops outwards and, for a class, only until they hold a
/// share of it that leaves no room for a candidate (a third, with [`SIZE_RATIO`] 2; the median
/// and middle half of such a class are those of the part reached): on most scans every class
/// stops there and the step costs a fraction of one pass over the volume.
pub fn settle_undrawn(volume: &Volume, labels: &mut [u8], lassoed: &[(usize, u8)]) -> Settled {
    let [size_x, size_y, size_z] = volume.dims;
    let mut settled = Settled::default();
    if lassoed.is_empty() || labels.len() != size_x * size_y * size_z {
        return settled;
    }
    let mut totals = [0usize; 256];
    for &label in labels.iter() {
        totals[label as usize] += 1;
    }
    let mut seeds: Vec<Vec<usize>> = vec![Vec::new(); 256];
    for &(voxel, class) in lassoed {
        if class != 0 && labels.get(voxel) == Some(&class) {
            seeds[class as usize].push(voxel);
        }
    }
    let mut reached = vec![false; labels.len()];
    let mut drawn_values: Vec<Vec<f64>> = vec![Vec::new(); 256];
    // Per class with room for a candidate, the size of its drawn pieces.
    let mut open: [Option<usize>; 256] = [None; 256];
    for class in 1..=u8::MAX {
        let seeds = &seeds[class as usize];
        if seeds.is_empty() {
            continue;
        }
        let enough = totals[class as usize].div_ceil(SIZE_RATIO + 1);
        let step = (totals[class as usize] / MEDIAN_SAMPLES).max(1);
        let mut sample = |voxel: usize, count: usize| {
            if count % step == 0 {
                let value = volume.value(voxel);
                if value.is_finite() {
                    drawn_values[class as usize].push(value);
                }
            }
        };
        let size = flood(labels, volume.dims, &mut reached, seeds, Some(enough), &mut sample);
        if size < enough {
            open[class as usize] = Some(size);
        }
    }
    if open.iter().all(Option::is_none) {
        return settled;
    }
    let medians: Vec<f64> = drawn_values
        .iter_mut()
        .map(|values| if values.is_empty() { f64::NAN } else { median_in_place(values) })
        .collect();
    // An open class's drawn values' middle half and range, where enough of them stand for it
    // (only an open class has candidates, and a candidate is held against its own class's).
    let spreads: Vec<Option<DrawnSpread>> = drawn_values
        .iter_mut()
        .zip(&open)
        .map(|(values, open)| {
            if open.is_none() || values.len() < MIN_CORE_VOXELS {
                return None;
            }
            values.sort_unstable_by(f64::total_cmp);
            let [low, _, high] = quartiles(values);
            let range = (quantile(values, BAND_TRIM), quantile(values, 1.0 - BAND_TRIM));
            Some(DrawnSpread { middle_half: (low, high), range })
        })
        .collect();
    // One pass finds every undrawn piece of an open class (the drawn ones are reached already).
    for start in 0..labels.len() {
        let class = labels[start];
        let Some(drawn_size) = open[class as usize].filter(|_| !reached[start]) else { continue };
        let mut piece = Vec::new();
        flood(labels, volume.dims, &mut reached, &[start], None, &mut |voxel, _| piece.push(voxel));
        if piece.len() <= SIZE_RATIO * drawn_size {
            continue;
        }
        let piece_step = (piece.len() / MEDIAN_SAMPLES).max(1);
        let mut values: Vec<f64> =
            piece.iter().step_by(piece_step).map(|&voxel| volume.value(voxel)).filter(|v| v.is_finite()).collect();
        if values.is_empty() {
            continue;
        }
        let median = median_in_place(&mut values);
        let distance = |label: usize| (median - medians[label]).abs();
        let nearest = (1..256usize)
            .filter(|&label| label != class as usize && medians[label].is_finite())
            .min_by(|&a, &b| distance(a).total_cmp(&distance(b)));
        let far_larger = piece.len() > NO_CLASS_RATIO * drawn_size;
        let spread = spreads[class as usize].filter(|_| far_larger);
        let target = match nearest.filter(|&label| distance(label) < distance(class as usize)) {
            Some(label) => label as u8,
            None => match spread {
                Some(DrawnSpread { middle_half: (low, high), .. }) if !(low..=high).contains(&median) => 0,
                Some(DrawnSpread { range, .. }) => {
                    settled.unlabelled += unlabel_undrawn_voxels(volume, labels, &piece, range);
                    continue;
                }
                None => continue,
            },
        };
        for &voxel in &piece {
            labels[voxel] = target;
        }
        if target == 0 {
            settled.unlabelled += piece.len();
        } else {
            settled.relabelled += piece.len();
        }
    }
    settled
}

/// A class's drawn pieces' values: their middle half and their range (less [`BAND_TRIM`] at
/// each end).
#[derive(Clone, Copy, Debug)]
struct DrawnSpread {
    middle_half: (f64, f64),
    range: (f64, f64),
}

/// Gives the voxels of `piece` outside `range` no class when they are more than [`MIXED_SHARE`]
/// of it; returns how many it changed.
fn unlabel_undrawn_voxels(volume: &Volume, labels: &mut [u8], piece: &[usize], (low, high): (f64, f64)) -> usize {
    let undrawn: Vec<usize> =
        piece.iter().copied().filter(|&voxel| !(low..=high).contains(&volume.value(voxel))).collect();
    if (undrawn.len() as f64) <= MIXED_SHARE * piece.len() as f64 {
        return 0;
    }
    for &voxel in &undrawn {
        labels[voxel] = 0;
    }
    undrawn.len()
}

/// Reaches the 6-connected voxels of the label of `seeds` from them (`reached` marks them),
/// calling `visit` with each and how many came before it; stops at `limit` voxels. Returns the
/// voxels reached.
fn flood(
    labels: &[u8],
    dims: [usize; 3],
    reached: &mut [bool],
    seeds: &[usize],
    limit: Option<usize>,
    visit: &mut dyn FnMut(usize, usize),
) -> usize {
    let Some(&first) = seeds.first() else { return 0 };
    let label = labels[first];
    let mut queue: VecDeque<usize> = VecDeque::new();
    let mut count = 0;
    for &seed in seeds {
        if !reached[seed] && labels[seed] == label {
            reached[seed] = true;
            queue.push_back(seed);
        }
    }
    while let Some(voxel) = queue.pop_front() {
        visit(voxel, count);
        count += 1;
        if limit.is_some_and(|limit| count >= limit) {
            break;
        }
        for face in faces_of(voxel, dims).into_iter().flatten() {
            if !reached[face] && labels[face] == label {
                reached[face] = true;
                queue.push_back(face);
            }
        }
    }
    count
}

#[cfg(test)]
mod tests;
