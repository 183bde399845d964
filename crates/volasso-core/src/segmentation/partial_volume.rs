//! Partial-volume layers, the last of the spatial step. A blurred border between two tissues
//! passes through every intensity between theirs; where a third class's intensity lies there,
//! the classifier gives the border that class: a one-voxel shell of "cell" round each bright
//! granule in a culture medium, a sheet of "lesion" between the body wall's fat and muscle.
//! Such a layer is a piece of the class (6-connected voxels) that no loop touches, with almost
//! no interior ([`THIN_SHARE`] of what its class's drawn pieces have, or with a learned preset,
//! which draws none, its thickest piece), one voxel thick ([`SANDWICHED_SHARE`]), lying between
//! two classes whose medians bracket its class's ([`SIDE_SHARE`]). Each of its voxels takes the
//! neighbouring class whose median is nearest its intensity
//! (`docs/decisions/0020-partial-volume-layers.md`).
//!
//! Never: changes a piece a loop touches, background (label 0), or any piece of a class drawn
//! on a thin structure ([`THICK_SHARE`]: a vessel or a joint space is thin everywhere); reads
//! the classifier.

use super::background::median_in_place;
use super::neighbours::{cube_around, faces_of};
use crate::volume::Volume;

/// A piece is a layer when the share of its voxels whose six faces are all its class is at most
/// this fraction of the share its class's drawn pieces have.
pub const THIN_SHARE: f64 = 0.1;

/// A class whose drawn pieces' share of interior voxels is below this is drawn on a thin
/// structure (a vessel, a joint space 2-3 voxels across) and keeps every piece: the foot's other
/// joint spaces went to bone and soft tissue (joint Dice 0.60 -> 0.46) without it.
pub const THICK_SHARE: f64 = 0.1;

/// A layer is one voxel thick: at least this share of its voxels has, along one axis, two other
/// classes on its two faces. A tissue two or three voxels thick (the CSF round a brain, drawn
/// in the ventricles only) is one of its own: it went to the skull and the grey matter (CSF Dice
/// 0.92 -> 0.17) without it.
pub const SANDWICHED_SHARE: f64 = 0.25;

/// A class is on one side of a piece when it holds at least this share of the piece's faces
/// with other classes.
pub const SIDE_SHARE: f64 = 0.15;

/// Fewest voxels of the piece that stands for a class without drawn pieces.
pub const MIN_REFERENCE_VOXELS: u32 = 64;

/// Intensities sampled per class for its median, at most (every k-th voxel).
const MEDIAN_SAMPLES: usize = 1_000_000;

/// One 6-connected piece of one label.
#[derive(Clone, Copy, Default)]
struct Piece {
    label: u8,
    size: u32,
    interior: u32,
    drawn: bool,
}

/// Gives the voxels of every partial-volume layer (see the module doc) the neighbouring class
/// whose median is nearest their intensity; `lassoed`: the voxels the user drew with their
/// class ids. Returns the voxels changed.
pub fn settle_layers(volume: &Volume, labels: &mut [u8], lassoed: &[(usize, u8)]) -> usize {
    let [size_x, size_y, size_z] = volume.dims;
    let plane = size_x * size_y;
    if plane == 0 || labels.len() != plane * size_z || labels.len() >= u32::MAX as usize {
        return 0;
    }
    // Only a class whose median lies between two others' can form a layer: the others' voxels
    // make no pieces (with fewer than three classes, nothing to do).
    let medians = class_medians(volume, labels);
    let present = || medians.iter().skip(1).filter(|median| median.is_finite());
    let lowest = present().copied().fold(f32::INFINITY, f32::min);
    let highest = present().copied().fold(f32::NEG_INFINITY, f32::max);
    let middle: Vec<bool> =
        medians.iter().enumerate().map(|(label, &m)| label != 0 && lowest < m && m < highest).collect();
    if !middle.contains(&true) {
        return 0;
    }
    let (piece_of, mut pieces) = pieces(labels, volume.dims, &middle);
    for &(voxel, class) in lassoed {
        if labels.get(voxel) == Some(&class) && piece_of[voxel] != u32::MAX {
            pieces[piece_of[voxel] as usize].drawn = true;
        }
    }
    let reference = reference_shares(&pieces);
    let thin: Vec<bool> = pieces
        .iter()
        .map(|piece| {
            let share = reference[piece.label as usize];
            !piece.drawn
                && share >= THICK_SHARE
                && f64::from(piece.interior) <= THIN_SHARE * share * f64::from(piece.size)
        })
        .collect();
    if !thin.contains(&true) {
        return 0;
    }
    let layers = between_two_classes(labels, volume.dims, &piece_of, &pieces, &thin, &medians);
    let mut changes = Vec::new();
    for (voxel, &piece) in piece_of.iter().enumerate() {
        if piece == u32::MAX || !layers[piece as usize] {
            continue;
        }
        let own = labels[voxel];
        let value = volume.value(voxel) as f32;
        let nearest = cube_around(voxel, volume.dims)
            .map(|neighbour| labels[neighbour])
            .filter(|&label| label != own && label != 0 && medians[label as usize].is_finite())
            .min_by(|&a, &b| (value - medians[a as usize]).abs().total_cmp(&(value - medians[b as usize]).abs()));
        if let Some(label) = nearest {
            changes.push((voxel, label));
        }
    }
    for &(voxel, label) in &changes {
        labels[voxel] = label;
    }
    changes.len()
}

/// Per label, the interior share a piece of its class has where it is a structure of its own:
/// its drawn pieces' (interior voxels over voxels); for a class without drawn pieces (a learned
/// preset's), its thickest piece's of at least [`MIN_REFERENCE_VOXELS`].
fn reference_shares(pieces: &[Piece]) -> Vec<f64> {
    let mut drawn = vec![(0u64, 0u64); 256];
    let mut thickest = vec![0f64; 256];
    for piece in pieces {
        let label = piece.label as usize;
        if piece.drawn {
            drawn[label].0 += u64::from(piece.size);
            drawn[label].1 += u64::from(piece.interior);
        } else if piece.size >= MIN_REFERENCE_VOXELS {
            thickest[label] = thickest[label].max(f64::from(piece.interior) / f64::from(piece.size));
        }
    }
    drawn
        .iter()
        .zip(&thickest)
        .map(|(&(size, interior), &thickest)| if size > 0 { interior as f64 / size as f64 } else { thickest })
        .collect()
}

/// Every voxel's piece (6-connected voxels of one label that `counts`; `u32::MAX` for the
/// others) and the pieces, numbered in the order of their first voxel.
fn pieces(labels: &[u8], dims: [usize; 3], counts: &[bool]) -> (Vec<u32>, Vec<Piece>) {
    let [size_x, size_y, size_z] = dims;
    let plane = size_x * size_y;
    // Union-find whose roots are each piece's first voxel (the lower root always wins).
    let mut parent: Vec<u32> = (0..labels.len() as u32).collect();
    fn root(parent: &mut [u32], mut voxel: u32) -> u32 {
        while parent[voxel as usize] != voxel {
            let up = parent[parent[voxel as usize] as usize];
            parent[voxel as usize] = up;
            voxel = up;
        }
        voxel
    }
    for z in 0..size_z {
        for y in 0..size_y {
            let start = size_x * (y + size_y * z);
            for x in 0..size_x {
                let voxel = start + x;
                let label = labels[voxel];
                if !counts[label as usize] {
                    continue;
                }
                for (has, before) in [(x > 0, 1), (y > 0, size_x), (z > 0, plane)] {
                    if has && labels[voxel - before] == label {
                        let (a, b) = (root(&mut parent, voxel as u32), root(&mut parent, (voxel - before) as u32));
                        if a != b {
                            parent[a.max(b) as usize] = a.min(b);
                        }
                    }
                }
            }
        }
    }
    // Every counted voxel points at its root.
    for voxel in 0..labels.len() {
        if counts[labels[voxel] as usize] {
            parent[voxel] = root(&mut parent, voxel as u32);
        }
    }
    // In voxel order a root comes before the rest of its piece: its entry becomes the piece's
    // number, which the rest read through it.
    let mut pieces: Vec<Piece> = Vec::new();
    for voxel in 0..labels.len() {
        let label = labels[voxel];
        if !counts[label as usize] {
            parent[voxel] = u32::MAX;
            continue;
        }
        let top = parent[voxel] as usize;
        let piece = if top == voxel {
            pieces.push(Piece { label, ..Piece::default() });
            (pieces.len() - 1) as u32
        } else {
            parent[top]
        };
        parent[voxel] = piece;
        let piece = &mut pieces[piece as usize];
        piece.size += 1;
        let inside = faces_of(voxel, dims).iter().all(|face| face.is_none_or(|face| labels[face] == label));
        piece.interior += u32::from(inside);
    }
    (parent, pieces)
}

/// Each label's median intensity (NaN for a label no voxel has), over every k-th voxel.
fn class_medians(volume: &Volume, labels: &[u8]) -> Vec<f32> {
    let step = (labels.len() / MEDIAN_SAMPLES).max(1);
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); 256];
    for voxel in (0..labels.len()).step_by(step) {
        let value = volume.value(voxel);
        if value.is_finite() {
            values[labels[voxel] as usize].push(value);
        }
    }
    values.iter_mut().map(|values| if values.is_empty() { f32::NAN } else { median_in_place(values) as f32 }).collect()
}

/// Of the `thin` pieces, those lying between two classes: one voxel thick
/// ([`SANDWICHED_SHARE`]), at least two other classes hold [`SIDE_SHARE`] of its faces with other
/// classes each, and its class's median lies strictly between theirs.
fn between_two_classes(
    labels: &[u8],
    dims: [usize; 3],
    piece_of: &[u32],
    pieces: &[Piece],
    thin: &[bool],
    medians: &[f32],
) -> Vec<bool> {
    // Dense counts: per thin piece, its faces with each label present, and its sandwiched voxels.
    let present: Vec<u8> = (1..=u8::MAX).filter(|&label| medians[label as usize].is_finite()).collect();
    let mut slot = [usize::MAX; 256];
    for (index, &label) in present.iter().enumerate() {
        slot[label as usize] = index;
    }
    let mut row = vec![u32::MAX; pieces.len()];
    let mut rows = 0usize;
    for (piece, _) in thin.iter().enumerate().filter(|&(_, &thin)| thin) {
        row[piece] = rows as u32;
        rows += 1;
    }
    let width = present.len();
    let mut contacts = vec![0u32; rows * width];
    let mut sandwiched = vec![0u32; rows];
    for (voxel, &piece) in piece_of.iter().enumerate() {
        if piece == u32::MAX || row[piece as usize] == u32::MAX {
            continue;
        }
        let at = row[piece as usize] as usize;
        let own = labels[voxel];
        let faces = faces_of(voxel, dims);
        for face in faces.iter().flatten() {
            let label = labels[*face];
            if label != own && slot[label as usize] != usize::MAX {
                contacts[at * width + slot[label as usize]] += 1;
            }
        }
        let between = faces.chunks_exact(2).any(|pair| match (pair[0], pair[1]) {
            (Some(a), Some(b)) => {
                let (a, b) = (labels[a], labels[b]);
                a != own && b != own && a != 0 && b != 0 && a != b
            }
            _ => false,
        });
        sandwiched[at] += u32::from(between);
    }
    let mut layers = vec![false; pieces.len()];
    for (piece, &at) in row.iter().enumerate().filter(|&(_, &at)| at != u32::MAX) {
        let counts = &contacts[at as usize * width..][..width];
        let total: u32 = counts.iter().sum();
        let bracket = counts
            .iter()
            .zip(&present)
            .filter(|&(&count, _)| count > 0 && f64::from(count) >= SIDE_SHARE * f64::from(total))
            .map(|(_, &label)| medians[label as usize])
            .fold((f32::INFINITY, f32::NEG_INFINITY, 0), |(low, high, count), median| {
                (low.min(median), high.max(median), count + 1)
            });
        let own = medians[pieces[piece].label as usize];
        let one_voxel_thick = f64::from(sandwiched[at as usize]) >= SANDWICHED_SHARE * f64::from(pieces[piece].size);
        layers[piece] = one_voxel_thick && bracket.2 >= 2 && bracket.0 < own && own < bracket.1;
    }
    layers
}

#[cfg(test)]
mod tests;
