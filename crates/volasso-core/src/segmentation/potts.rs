//! Border voxels settle by a Potts model of the image after the majority filter
//! ([`super::coherence`]): each voxel with a face neighbour of another class takes the label,
//! among its own and its faces', of least
//! `E(k) = (I - m_k)^2 / (2 sigma^2) + BETA * (faces not k) + GAMMA * [k is not its label]`
//! (`m_k`: class `k`'s mean in the window around it; `sigma`: [`noise_deviation`]). The image
//! term puts a blurred border where the intensity crosses halfway, so partial-volume voxels do
//! not go to the wrong side, as beside a knee's bone (`docs/decisions/0018-potts-coherence.md`).
//!
//! Never: changes or counts background voxels (label 0), or reads a voxel outside the window.

use super::background::median_in_place;
use super::coherence::{Neighbourhood, face_labels};
use crate::volume::Volume;
use rayon::prelude::*;

/// Weight of each face neighbour of another label (one noise deviation from a local mean costs
/// 1/2): the border's length, which makes a speck join its surroundings; 0.5 and 2 score within
/// 0.006 of it (`docs/decisions/0018-potts-coherence.md`).
pub const BETA: f64 = 1.0;

/// Weight of leaving the label the voxel came with: the classifier's label stays where image and
/// neighbours do not speak against it; 2 scores lower (`docs/decisions/0018-potts-coherence.md`).
pub const GAMMA: f64 = 1.0;

/// Sweeps at most; two leave a cell phantom further below the forest
/// (`docs/decisions/0018-potts-coherence.md`).
pub const SWEEPS: usize = 4;

/// Radius in voxels of the window the local class means are taken in.
pub const WINDOW_RADIUS: usize = 2;

/// The scan's noise: 1.4826 x the median |difference| of x neighbours of one class over sqrt 2,
/// without clipped values (a windowed CT's lungs), whose zero noise makes every border a cliff.
pub fn noise_deviation(volume: &Volume, labels: &[u8]) -> f64 {
    let size_x = volume.dims[0].max(1);
    let range = volume.value_range();
    let unclipped = |value: f64| value > range.min && value < range.max;
    let step = (labels.len() / 200_000).max(1);
    let mut differences: Vec<f64> = (0..labels.len().saturating_sub(1))
        .step_by(step)
        .filter(|&index| index % size_x + 1 < size_x && labels[index] != 0 && labels[index] == labels[index + 1])
        .map(|index| (volume.value(index), volume.value(index + 1)))
        .filter(|&(a, b)| unclipped(a) && unclipped(b))
        .map(|(a, b)| (a - b).abs())
        .collect();
    if differences.is_empty() {
        return 1.0;
    }
    (1.4826 * median_in_place(&mut differences) / std::f64::consts::SQRT_2).max(1e-6)
}

/// Runs the sweeps on `labels` (`volume`'s dims, x fastest); returns the voxels changed.
pub fn potts_sweeps(volume: &Volume, labels: &mut [u8], neighbourhood: Neighbourhood) -> usize {
    let [size_x, size_y, size_z] = volume.dims;
    let plane = size_x * size_y;
    if plane == 0 || labels.len() != plane * size_z {
        return 0;
    }
    let sigma = noise_deviation(volume, labels);
    let came_with: Vec<u8> = labels.to_vec();
    let depth = if neighbourhood == Neighbourhood::Cube { WINDOW_RADIUS } else { 0 };
    // Rows (y + size_y * z) to visit: all at first, then those within the window of a change.
    let mut visit = vec![true; size_y * size_z];
    let mut changed = 0;
    for _ in 0..SWEEPS {
        let sweep = Sweep {
            volume,
            labels: &*labels,
            came_with: &came_with,
            energy_scale: 1.0 / (2.0 * sigma * sigma),
            depth,
            across: neighbourhood == Neighbourhood::Cube,
        };
        let changes: Vec<Vec<(usize, u8)>> =
            (0..size_z).into_par_iter().map(|z| sweep.plane(z, &visit[z * size_y..][..size_y])).collect();
        visit.fill(false);
        let mut changed_here = 0;
        for &(voxel, label) in changes.iter().flatten() {
            labels[voxel] = label;
            changed_here += 1;
            let (y, z) = (voxel / size_x % size_y, voxel / plane);
            for wz in z.saturating_sub(depth.max(1))..(z + depth.max(1) + 1).min(size_z) {
                let rows = y.saturating_sub(WINDOW_RADIUS)..(y + WINDOW_RADIUS + 1).min(size_y);
                visit[wz * size_y..][rows].fill(true);
            }
        }
        changed += changed_here;
        if changed_here == 0 {
            break;
        }
    }
    log::debug!("potts: noise deviation {sigma:.3}, {changed} voxels changed");
    changed
}

/// One sweep's reading of the labels before it.
struct Sweep<'a> {
    volume: &'a Volume,
    labels: &'a [u8],
    came_with: &'a [u8],
    energy_scale: f64,
    /// Window radius across the slices (0 within the slice).
    depth: usize,
    /// Whether the slices above and below are face neighbours.
    across: bool,
}

impl Sweep<'_> {
    /// The changes of plane `z` in the rows `visit` marks: (voxel, its new label).
    fn plane(&self, z: usize, visit: &[bool]) -> Vec<(usize, u8)> {
        let [size_x, size_y, size_z] = self.volume.dims;
        let plane = size_x * size_y;
        let mut changes = Vec::new();
        // The window's planes as f32, each row read the first time a window reaches it.
        let planes = z.saturating_sub(self.depth)..(z + self.depth + 1).min(size_z);
        let mut values: Vec<f32> = Vec::new();
        let mut rows_read = vec![false; size_y];
        let here = &self.labels[z * plane..][..plane];
        let below = (self.across && z > 0).then(|| &self.labels[(z - 1) * plane..][..plane]);
        let above = (self.across && z + 1 < size_z).then(|| &self.labels[(z + 1) * plane..][..plane]);
        for y in (0..size_y).filter(|&y| visit[y]) {
            for x in 0..size_x {
                let own = here[y * size_x + x];
                if own == 0 {
                    continue;
                }
                // Outside the volume counts as background: it neither votes nor is a candidate.
                let faces = face_labels(below, here, above, size_x, size_y, x, y).map(|face| face.unwrap_or(0));
                if faces.iter().all(|&label| label == own || label == 0) {
                    continue;
                }
                if values.is_empty() {
                    values.resize(planes.len() * plane, 0.0);
                }
                for wy in y.saturating_sub(WINDOW_RADIUS)..(y + WINDOW_RADIUS + 1).min(size_y) {
                    if !rows_read[wy] {
                        rows_read[wy] = true;
                        for (wz, out) in planes.clone().zip(values.chunks_exact_mut(plane)) {
                            self.volume.read_f32(wz * plane + wy * size_x, &mut out[wy * size_x..][..size_x]);
                        }
                    }
                }
                let voxel = z * plane + y * size_x + x;
                let best = self.best_label(voxel, [x, y, z], &faces, &values, planes.start);
                if best != own {
                    changes.push((voxel, best));
                }
            }
        }
        changes
    }

    /// The label of least energy for `voxel` among its own and its `faces'`.
    fn best_label(
        &self,
        voxel: usize,
        [x, y, z]: [usize; 3],
        faces: &[u8; 6],
        values: &[f32],
        first_plane: usize,
    ) -> u8 {
        let [size_x, size_y, size_z] = self.volume.dims;
        let plane = size_x * size_y;
        let own = self.labels[voxel];
        // (label, sum, count) per candidate; `slot[label]`: its position plus one (0: none).
        let mut candidates = [(0u8, 0.0f64, 0u32); 7];
        let mut slot = [0u8; 256];
        candidates[0].0 = own;
        slot[usize::from(own)] = 1;
        let mut count = 1;
        for &label in faces {
            if label != 0 && slot[usize::from(label)] == 0 {
                candidates[count].0 = label;
                count += 1;
                slot[usize::from(label)] = count as u8;
            }
        }
        let (mut sums, mut counts) = ([0f32; 8], [0u32; 8]);
        let columns = x.saturating_sub(WINDOW_RADIUS)..(x + WINDOW_RADIUS + 1).min(size_x);
        for wz in z.saturating_sub(self.depth)..(z + self.depth + 1).min(size_z) {
            let plane_values = &values[(wz - first_plane) * plane..][..plane];
            for wy in y.saturating_sub(WINDOW_RADIUS)..(y + WINDOW_RADIUS + 1).min(size_y) {
                let row = wy * size_x;
                let row_labels = &self.labels[wz * plane + row..][..size_x][columns.clone()];
                let row_values = &plane_values[row..][..size_x][columns.clone()];
                for (&label, &value) in row_labels.iter().zip(row_values) {
                    let position = usize::from(slot[usize::from(label)]);
                    sums[position] += value;
                    counts[position] += 1;
                }
            }
        }
        let candidates = &mut candidates[..count];
        for (position, candidate) in candidates.iter_mut().enumerate() {
            candidate.1 = f64::from(sums[position + 1]);
            candidate.2 = counts[position + 1];
        }
        // The voxel itself is not its own evidence.
        let intensity = f64::from(values[(z - first_plane) * plane + y * size_x + x]);
        candidates[0].1 -= intensity;
        candidates[0].2 -= 1;
        let energy = |&(label, sum, count): &(u8, f64, u32)| {
            if count == 0 {
                return f64::INFINITY;
            }
            let mean = sum / f64::from(count);
            let disagreeing = faces.iter().filter(|&&face| face != 0 && face != label).count();
            let moved = if label == self.came_with[voxel] { 0.0 } else { GAMMA };
            (intensity - mean).powi(2) * self.energy_scale + BETA * disagreeing as f64 + moved
        };
        let mut best = (energy(&candidates[0]), own);
        for candidate in candidates.iter().skip(1) {
            let candidate_energy = energy(candidate);
            if candidate_energy < best.0 {
                best = (candidate_energy, candidate.0);
            }
        }
        best.1
    }
}

#[cfg(test)]
mod tests;
