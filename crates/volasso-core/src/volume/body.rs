//! The scanned body: which voxels lie inside the outline of the patient (or the object) and
//! which lie in the world around it. Found once per volume, from the volume alone
//! ([`Volume::body`]); the segmentation never classifies a voxel outside it unless the user
//! drew a loop out there.
//!
//! [`Body::find`]:
//! 1. **The air level**: the volume's Otsu threshold ([`Volume::otsu_threshold`]), which
//!    splits the air (and whatever the scanner put outside its field of view) from the body in
//!    CT and MRI alike ([`Volume::body`]), or a level the segmentation's background rule chose
//!    ([`Volume::body_at`]).
//! 2. **Holes filled slice by slice**: the voxels at or above the level, then in every axial
//!    slice (the voxel axis nearest the patient's head-to-feet axis where the file says, else
//!    z) the dark voxels that no path of dark voxels joins to the slice's edge. The lungs, the
//!    airways, sinuses and bowel gas are inside, even where they reach a face of the volume
//!    (the trachea leaves a chest CT through its top face; in the axial slices the chest wall
//!    still rings it). Only the axial slices: in the others the air between a patient's arm and
//!    side, or between a specimen's legs, would be ringed too.
//! 3. **Specks dropped**: parts (6-connected) of fewer than [`MIN_PART_VOXELS`] voxels are the
//!    air's noise (an MRI's Rician air), not a body.
//!
//! Never: looks at lassos or classes, or decides which dark voxels inside the body are
//! classified (that is the segmentation's).

use super::Volume;
use rayon::prelude::*;

/// A connected part of the body smaller than this is the air's noise.
pub const MIN_PART_VOXELS: usize = 16;

/// The voxels inside the scanned body.
#[derive(Clone, Debug)]
pub struct Body {
    /// The volume's size in voxels (x, y, z).
    pub dims: [usize; 3],
    /// The air level: voxels below it are dark (air) unless a slice's outline encloses them.
    pub level: f64,
    /// One bit per voxel (x fastest): set inside the body.
    words: Vec<u64>,
    /// Per row (y fastest), the first and last x inside; first > last for a row without.
    rows: Vec<[u32; 2]>,
    /// Voxels inside.
    count: usize,
}

impl Body {
    /// The body of `volume` above `level` (see the module doc). Costs a few passes over the
    /// volume, run in parallel over slices.
    pub fn find(volume: &Volume, level: f64) -> Body {
        let plane = volume.dims[0] * volume.dims[1];
        let mut mask = vec![0u8; volume.voxel_count()];
        mask.par_chunks_mut(plane.max(1)).enumerate().for_each_init(
            || vec![0f32; plane],
            |buffer, (z, out)| {
                volume.read_z_slice_f32(z, buffer);
                for (m, &value) in out.iter_mut().zip(buffer.iter()) {
                    *m = u8::from(f64::from(value) >= level);
                }
            },
        );
        let axial = volume
            .orientation
            .as_ref()
            .map_or(2, |orientation| orientation.voxel_axis_toward(super::orientation::PatientDirection::Superior).0);
        fill_holes(&mut mask, volume.dims, axial);
        drop_specks(&mut mask, volume.dims, MIN_PART_VOXELS);
        Body::from_mask(volume.dims, level, &mask)
    }

    /// A body from a mask (non-zero inside), x fastest.
    pub fn from_mask(dims: [usize; 3], level: f64, mask: &[u8]) -> Body {
        let mut words = vec![0u64; mask.len().div_ceil(64)];
        let mut count = 0;
        for (word, chunk) in words.iter_mut().zip(mask.chunks(64)) {
            for (bit, &m) in chunk.iter().enumerate() {
                if m != 0 {
                    *word |= 1 << bit;
                    count += 1;
                }
            }
        }
        let rows = mask
            .chunks(dims[0].max(1))
            .map(|row| match (row.iter().position(|&m| m != 0), row.iter().rposition(|&m| m != 0)) {
                (Some(first), Some(last)) => [first as u32, last as u32],
                _ => [1, 0],
            })
            .collect();
        Body { dims, level, words, rows, count }
    }

    /// Whether voxel `index` (x fastest) lies inside the body.
    #[inline]
    pub fn contains(&self, index: usize) -> bool {
        self.words[index / 64] >> (index % 64) & 1 == 1
    }

    /// The voxels outside the body, ascending (x fastest).
    pub fn outside(&self) -> impl Iterator<Item = usize> + '_ {
        let voxels = self.dims[0] * self.dims[1] * self.dims[2];
        let words = self.words.iter().enumerate().flat_map(|(index, &word)| {
            let mut rest = !word;
            std::iter::from_fn(move || {
                (rest != 0).then(|| {
                    let bit = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    index * 64 + bit
                })
            })
        });
        words.take_while(move |&voxel| voxel < voxels)
    }

    /// Voxels inside the body.
    pub fn voxel_count(&self) -> usize {
        self.count
    }

    /// The first and last x of row (y, z) inside the body; `None` when none is.
    pub fn row_span(&self, y: usize, z: usize) -> Option<(usize, usize)> {
        let [first, last] = *self.rows.get(y + self.dims[1] * z)?;
        (first <= last).then_some((first as usize, last as usize))
    }
}

/// Sets every voxel that is a hole of `mask` in a slice across `axis` (a 0 that no 4-connected
/// path of 0s joins to the slice's edge).
fn fill_holes(mask: &mut [u8], dims: [usize; 3], axis: usize) {
    let [nx, ny, nz] = dims;
    // (slice count, slice width, slice height, index of (u, v) in slice s)
    type Index = fn([usize; 3], usize, usize, usize) -> usize;
    let axes: [(usize, usize, usize, Index); 1] = [match axis {
        0 => (nx, ny, nz, |d, s, u, v| s + d[0] * (u + d[1] * v)),
        1 => (ny, nx, nz, |d, s, u, v| u + d[0] * (s + d[1] * v)),
        _ => (nz, nx, ny, |d, s, u, v| u + d[0] * (v + d[1] * s)),
    }];
    let given: &[u8] = mask;
    // Per axis and slice, the holes as bits (u + width v): a slice's worth of bits, not a list
    // of voxels (a chest's lungs are millions).
    let holes: Vec<Vec<(usize, Vec<u64>)>> = axes
        .iter()
        .map(|&(count, width, height, index)| {
            (0..count)
                .into_par_iter()
                .map_init(Vec::new, |slice: &mut Vec<u8>, s| {
                    slice.clear();
                    slice.extend((0..height).flat_map(|v| (0..width).map(move |u| given[index(dims, s, u, v)])));
                    (s, slice_holes(slice, width, height))
                })
                .filter(|(_, bits)| bits.iter().any(|&w| w != 0))
                .collect()
        })
        .collect();
    for (&(_, width, _, index), slices) in axes.iter().zip(&holes) {
        for (s, bits) in slices {
            for (w, &word) in bits.iter().enumerate() {
                let mut rest = word;
                while rest != 0 {
                    let k = w * 64 + rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    mask[index(dims, *s, k % width, k / width)] = 1;
                }
            }
        }
    }
}

/// The 0s of a slice that no 4-connected path of 0s joins to its edge, as bits (u + width v).
fn slice_holes(slice: &[u8], width: usize, height: usize) -> Vec<u64> {
    // 0: dark, not reached; 1: body; 2: dark and reached from the edge.
    let mut state: Vec<u8> = slice.iter().map(|&m| u8::from(m != 0)).collect();
    let mut stack: Vec<usize> = Vec::new();
    let push = |state: &mut [u8], stack: &mut Vec<usize>, k: usize| {
        if state[k] == 0 {
            state[k] = 2;
            stack.push(k);
        }
    };
    for u in 0..width {
        push(&mut state, &mut stack, u);
        push(&mut state, &mut stack, u + width * (height - 1));
    }
    for v in 0..height {
        push(&mut state, &mut stack, width * v);
        push(&mut state, &mut stack, width - 1 + width * v);
    }
    while let Some(k) = stack.pop() {
        let (u, v) = (k % width, k / width);
        if u > 0 {
            push(&mut state, &mut stack, k - 1);
        }
        if u + 1 < width {
            push(&mut state, &mut stack, k + 1);
        }
        if v > 0 {
            push(&mut state, &mut stack, k - width);
        }
        if v + 1 < height {
            push(&mut state, &mut stack, k + width);
        }
    }
    let mut bits = vec![0u64; state.len().div_ceil(64)];
    for (k, _) in state.iter().enumerate().filter(|(_, s)| **s == 0) {
        bits[k / 64] |= 1 << (k % 64);
    }
    bits
}

/// Clears every 6-connected part of `mask` with fewer than `min_voxels` voxels.
fn drop_specks(mask: &mut [u8], dims: [usize; 3], min_voxels: usize) {
    let [nx, ny, nz] = dims;
    // 1: inside, not yet visited; 2: visited (still inside).
    let mut part: Vec<usize> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    for start in 0..mask.len() {
        if mask[start] != 1 {
            continue;
        }
        // The part's voxels are kept only while it may still be a speck.
        part.clear();
        let mut size = 0;
        mask[start] = 2;
        stack.push(start);
        while let Some(k) = stack.pop() {
            size += 1;
            if size < min_voxels {
                part.push(k);
            }
            let (x, y, z) = (k % nx, k / nx % ny, k / (nx * ny));
            let neighbours = [
                (x > 0).then(|| k - 1),
                (x + 1 < nx).then(|| k + 1),
                (y > 0).then(|| k - nx),
                (y + 1 < ny).then(|| k + nx),
                (z > 0).then(|| k - nx * ny),
                (z + 1 < nz).then(|| k + nx * ny),
            ];
            for n in neighbours.into_iter().flatten() {
                if mask[n] == 1 {
                    mask[n] = 2;
                    stack.push(n);
                }
            }
        }
        if size < min_voxels {
            for &k in &part {
                mask[k] = 0;
            }
        }
    }
}

#[cfg(test)]
mod tests;
