//! A built-in demo volume: a procedural CT-like phantom of a foot and distal leg, with the
//! ground truth of every voxel, so the app and every test have data on a fresh machine.
//!
//! [`demo_foot`] gives 192 x 128 x 96 voxels of 0.8 x 0.8 x 1.2 mm (a 153.6 x 102.4 x 115.2 mm
//! field of view), signed 16-bit Hounsfield units. Contents (see [`anatomy`] for the shapes):
//! * air, -1000 HU;
//! * soft tissue: muscle ~28..52 HU (a slow random variation) under a 2.4 mm layer of
//!   subcutaneous fat at -90 HU;
//! * 22 bones (tibia, fibula, tarsals, metatarsals, phalanges, sesamoids), each with a dense
//!   cortex (1200..1450 HU, 1.0..2.6 mm) around noisier cancellous marrow (250..350 HU);
//! * joint space (cartilage and fluid, 105 HU) 2.4 mm thick between articulating bones, i.e.
//!   about 3 voxels across in-plane and 2 along z;
//! * partial-volume blur (separable kernel 1/8 [1 6 1] per axis) and Gaussian-like noise
//!   (sigma 12 HU), with marrow and cortex texture (sigma 60 and 35 HU) before the blur.
//!
//! Ground truth classes ([`Phantom::class_names`]): 0 air, 1 soft tissue (muscle and fat: the
//! paper's "outer layer"), 2 bone (cortex and marrow together: a clinician lassos "bone", not
//! its layers), 3 joint. Truth is the tissue at each voxel centre before blur.
//!
//! What the paper's 5-D features can separate: air, soft tissue and bone, to Dice >= 0.9 from
//! lassos inside them on the top-entropy slices ([`lassos_inside`]; a 5-nearest-neighbour
//! stand-in classifier scores about 0.99, 0.93, 0.95). The joint space cannot be: at 2-3
//! voxels it is all partial volume, and its intermediate values are also those of every
//! bone surface's blurred edge, so voxel features reaching one voxel out mistake the whole
//! bone-soft tissue interface for joint (Dice about 0.1-0.5). It stays in the truth as the
//! benchmark for richer features (`volasso accuracy`); the acceptance class set is air, soft tissue, bone.
//!
//! Generation is deterministic (noise comes from a hash of seed and voxel index, not from a
//! stream, so the thread schedule cannot change a bit) and parallel over z slices.
//!
//! [`lassos_inside`] draws the lassos a careful user would on the top-entropy slices (so this
//! module uses `slices` and `strokes`, as a demo session does).
//!
//! [`procedural`] adds the accuracy harness's other phantoms (8-bit CT with vessels, 16-bit
//! MRI brain, 8-bit MRI shells), and [`bodies`] two with bodies cut by the volume's faces
//! (16-bit CT torso, 8-bit MRI head).
//!
//! [`source`] names where a volume comes from (a path, or this demo as "demo") and opens it.
//!
//! Never: reads files (but for [`source`], through `volume::open`), or pretends to be real
//! anatomy beyond a test's needs.

pub mod anatomy;
pub mod bodies;
pub(crate) mod lassos;
pub mod procedural;
pub mod source;
#[cfg(test)]
mod tests;

pub use lassos::lassos_inside;

use crate::rng::{gaussian_from_bits, hash64, unit_f64};
use crate::volume::{ByteOrder, ValueScale, Volume, VolumeError, VoxelBytes, VoxelType};
use anatomy::{FIELD_OF_VIEW_MM, RowShapes, Tissue};
use rayon::prelude::*;
use std::path::Path;

/// Voxels of the standard demo volume.
pub const DEMO_FOOT_DIMS: [usize; 3] = [192, 128, 96];
/// Voxel spacing of the standard demo volume (x, y, z), in mm.
pub const DEMO_FOOT_SPACING_MM: [f64; 3] = [0.8, 0.8, 1.2];
/// The seed of the standard demo volume.
pub const DEMO_FOOT_SEED: u64 = 0x5EED_F007;

/// CT noise after blur, marrow and cortex texture before it (HU, standard deviation).
const NOISE_HU: f32 = 12.0;
const MARROW_TEXTURE_HU: f32 = 60.0;
const CORTEX_TEXTURE_HU: f32 = 35.0;
const JOINT_TEXTURE_HU: f32 = 8.0;
/// Muscle varies slowly by up to this much around its mean, on a lattice of this pitch.
const MUSCLE_VARIATION_HU: f32 = 12.0;
const MUSCLE_LATTICE_MM: f64 = 12.0;

/// A generated volume with its ground truth.
#[derive(Debug)]
pub struct Phantom {
    /// Owned bytes: signed 16-bit HU for the demo foot, see [`procedural`] for the others.
    pub volume: Volume,
    /// The true class of every voxel (x fastest), an index into `class_names`; 0 is air.
    pub truth: Vec<u8>,
    /// Class names by class id.
    pub class_names: Vec<&'static str>,
}

impl Phantom {
    /// Voxels of each class, by class id.
    pub fn class_voxel_counts(&self) -> Vec<usize> {
        let mut counts = vec![0; self.class_names.len()];
        for &class in &self.truth {
            counts[class as usize] += 1;
        }
        counts
    }
}

/// The standard demo foot (192 x 128 x 96, 0.8 x 0.8 x 1.2 mm, seed [`DEMO_FOOT_SEED`]).
pub fn demo_foot() -> Phantom {
    match demo_foot_with(DEMO_FOOT_DIMS, DEMO_FOOT_SEED) {
        Ok(phantom) => phantom,
        // The standard dimensions are valid; no input reaches this.
        Err(error) => unreachable!("the standard demo foot is valid: {error}"),
    }
}

/// The demo foot sampled on `dims` voxels over the same field of view (spacing = field of
/// view / dims, so small sizes make quick test volumes; thin structures vanish below about
/// 1 mm per voxel). `seed` changes the noise only, never the anatomy or the truth.
pub fn demo_foot_with(dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
    let source = Path::new("<demo foot phantom>");
    let voxel_count = crate::volume::checked_voxel_count(dims, VoxelType::I16, source)?;
    // Scaled from the standard spacing, so the standard size gets exactly 0.8 x 0.8 x 1.2 mm.
    let spacing_mm: [f64; 3] =
        std::array::from_fn(|a| DEMO_FOOT_SPACING_MM[a] * (DEMO_FOOT_DIMS[a] as f64 / dims[a] as f64));
    let plane = dims[0] * dims[1];
    let muscle = MuscleVariation::new(seed);

    // 1. Tissue at every voxel centre, base HU with texture, blurred in-plane.
    let mut hounsfield = vec![0f32; voxel_count];
    let mut truth = vec![0u8; voxel_count];
    hounsfield.par_chunks_mut(plane).zip(truth.par_chunks_mut(plane)).enumerate().for_each(
        |(z, (slice, slice_truth))| {
            let z_mm = z as f64 * spacing_mm[2];
            for y in 0..dims[1] {
                let y_mm = y as f64 * spacing_mm[1];
                let row = y * dims[0]..(y + 1) * dims[0];
                let shapes = RowShapes::for_row(y_mm, z_mm);
                if shapes.is_empty() {
                    slice[row].fill(anatomy::AIR_HU);
                    continue;
                }
                let row_truth = &mut slice_truth[row.clone()];
                let row_values = &mut slice[row];
                let first_index = z * plane + y * dims[0];
                shapes.walk(y_mm, z_mm, spacing_mm[0], dims[0], |x, p, tissue| {
                    row_truth[x] = tissue.class();
                    row_values[x] = base_hounsfield(tissue, p, first_index + x, seed, &muscle);
                });
            }
            blur_rows(slice, dims[0], 1);
            blur_rows(slice, dims[0] * dims[1], dims[0]);
        },
    );

    // 2. Blur along z, add noise, round to int16 (little-endian bytes).
    let mut bytes = vec![0u8; voxel_count * 2];
    let noise_seed = hash64(seed, 0x004E_015E);
    bytes.par_chunks_mut(plane * 2).enumerate().for_each(|(z, out)| {
        let below = &hounsfield[z.saturating_sub(1) * plane..][..plane];
        let here = &hounsfield[z * plane..][..plane];
        let above = &hounsfield[(z + 1).min(dims[2] - 1) * plane..][..plane];
        for k in 0..plane {
            let blurred = (below[k] + 6.0 * here[k] + above[k]) * 0.125;
            let noise = NOISE_HU * gaussian_from_bits(hash64(noise_seed, (z * plane + k) as u64));
            let value = (blurred + noise).round().clamp(-1024.0, 3071.0) as i16;
            out[2 * k..2 * k + 2].copy_from_slice(&value.to_le_bytes());
        }
    });
    drop(hounsfield);

    let volume = Volume::new(
        dims,
        spacing_mm,
        VoxelType::I16,
        ByteOrder::Little,
        ValueScale::IDENTITY,
        VoxelBytes::Owned(bytes),
        source,
    )?;
    Ok(Phantom { volume, truth, class_names: anatomy::CLASS_NAMES.to_vec() })
}

/// HU of `tissue` at `p` before blur and noise, with per-voxel texture from `(seed, index)`.
fn base_hounsfield(tissue: Tissue, p: [f64; 3], index: usize, seed: u64, muscle: &MuscleVariation) -> f32 {
    let texture = || gaussian_from_bits(hash64(seed, index as u64));
    match tissue {
        Tissue::Air => anatomy::AIR_HU,
        Tissue::Fat => anatomy::FAT_HU,
        Tissue::Muscle => anatomy::MUSCLE_HU + muscle.at(p),
        Tissue::Joint => anatomy::JOINT_HU + JOINT_TEXTURE_HU * texture(),
        Tissue::Cortex(bone) => anatomy::BONES[bone].cortex_hu + CORTEX_TEXTURE_HU * texture(),
        Tissue::Marrow(bone) => anatomy::BONES[bone].marrow_hu + MARROW_TEXTURE_HU * texture(),
    }
}

/// Blurs `values` with 1/8 [1 6 1] along one axis, in place: each run of `run_length` values
/// (a row of x, or a whole plane for y) is blurred between elements `step` apart, with the
/// edge clamped.
fn blur_rows(values: &mut [f32], run_length: usize, step: usize) {
    let mut original = vec![0f32; run_length];
    for run in values.chunks_exact_mut(run_length) {
        original.copy_from_slice(run);
        let lines = run_length / step;
        for (k, value) in run.iter_mut().enumerate() {
            let line = k / step;
            let before = if line == 0 { k } else { k - step };
            let after = if line + 1 == lines { k } else { k + step };
            *value = (original[before] + 6.0 * original[k] + original[after]) * 0.125;
        }
    }
}

/// Slow random variation of muscle HU: random values on a coarse lattice, trilinearly
/// interpolated.
struct MuscleVariation {
    size: [usize; 3],
    values: Vec<f32>,
}

impl MuscleVariation {
    fn new(seed: u64) -> MuscleVariation {
        let size: [usize; 3] = std::array::from_fn(|a| (FIELD_OF_VIEW_MM[a] / MUSCLE_LATTICE_MM).ceil() as usize + 2);
        let lattice_seed = hash64(seed, 0x03A7_71CE);
        let values = (0..size[0] * size[1] * size[2])
            .map(|k| MUSCLE_VARIATION_HU * (2.0 * unit_f64(hash64(lattice_seed, k as u64)) as f32 - 1.0))
            .collect();
        MuscleVariation { size, values }
    }

    fn at(&self, p: [f64; 3]) -> f32 {
        let mut cell = [0usize; 3];
        let mut fraction = [0f32; 3];
        for a in 0..3 {
            let position = (p[a] / MUSCLE_LATTICE_MM).clamp(0.0, (self.size[a] - 2) as f64);
            cell[a] = (position as usize).min(self.size[a] - 2);
            fraction[a] = (position - cell[a] as f64) as f32;
        }
        let at = |dx: usize, dy: usize, dz: usize| {
            self.values[(cell[0] + dx) + self.size[0] * ((cell[1] + dy) + self.size[1] * (cell[2] + dz))]
        };
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let [fx, fy, fz] = fraction;
        let x00 = lerp(at(0, 0, 0), at(1, 0, 0), fx);
        let x10 = lerp(at(0, 1, 0), at(1, 1, 0), fx);
        let x01 = lerp(at(0, 0, 1), at(1, 0, 1), fx);
        let x11 = lerp(at(0, 1, 1), at(1, 1, 1), fx);
        lerp(lerp(x00, x10, fy), lerp(x01, x11, fy), fz)
    }
}

/// Dice overlap 2|A ∩ B| / (|A| + |B|) of class `class` in `truth` and `labels` (1 when the
/// class is in neither).
pub fn dice(truth: &[u8], labels: &[u8], class: u8) -> f64 {
    let (mut both, mut in_truth, mut in_labels) = (0u64, 0u64, 0u64);
    for (&t, &l) in truth.iter().zip(labels) {
        let (t, l) = (t == class, l == class);
        both += (t && l) as u64;
        in_truth += t as u64;
        in_labels += l as u64;
    }
    if in_truth + in_labels == 0 { 1.0 } else { 2.0 * both as f64 / (in_truth + in_labels) as f64 }
}
