//! Procedural phantoms with known truth for the accuracy harness, beside the demo
//! foot: each is a function from a point in millimetres to a class, turned into a volume by
//! per-class values, texture, a smooth multiplicative bias field, partial-volume blur and noise.
//!
//! * [`vessels_ct`]: 8-bit CT-like abdomen. Air, soft tissue, an organ slightly brighter than
//!   tissue, contrast-filled vessels 1.2-5 mm in radius (thin tubes through the organ), and bone
//!   (a vertebral body with a bright cortex around marrow as dark as the organ, and thin ribs).
//! * [`brain_mri`]: 16-bit T1-like head. Background, scalp, skull, CSF, a folded cortical grey
//!   matter shell 2.5-4.5 mm thick, white matter; ventricles are CSF. A 30 % bias field.
//! * [`shells_mri`]: 8-bit MRI-like nested shells: background, a thin bright rind, flesh, a thin
//!   membrane, a dark core, and small seeds as bright as the rind (a thin sheet against a blob).
//!
//! All sizes are in millimetres over a fixed field of view, so `dims` only changes the
//! sampling (small dims make quick CI volumes). `seed` changes texture and noise only, never
//! the truth. Deterministic (hashed noise) and parallel over z planes.
//!
//! Never: reads files, or claims anatomical realism beyond what a classifier test needs.

use super::Phantom;
use crate::rng::{gaussian_from_bits, hash64};
use crate::volume::{ByteOrder, ValueScale, Volume, VolumeError, VoxelBytes, VoxelType};
use rayon::prelude::*;
use std::path::Path;

/// How one phantom turns truth into values.
pub(super) struct Recipe<'a> {
    pub name: &'static str,
    pub class_names: &'a [&'static str],
    pub field_of_view_mm: [f64; 3],
    /// U8 and U16 are magnitude images (noise folded at 0); I16 is CT in Hounsfield units
    /// (clamped to -1024..3071, the bias field acting on the value above air).
    pub voxel_type: VoxelType,
    /// Per tissue (what `tissue_at` returns): its class, mean value and texture deviation
    /// (before bias, blur and noise).
    pub tissues: &'a [(u8, f32, f32)],
    /// Relative amplitude of the smooth multiplicative bias field.
    pub bias: f32,
    /// Noise deviation after blur.
    pub noise: f32,
    /// Passes of the 1/8 [1 6 1] blur per axis.
    pub blur_passes: usize,
    /// An 8-bit CT stored through a display window: values below the window are clipped to
    /// 0 (the air and the lungs are all 0), not folded as a magnitude image's noise is.
    pub windowed: bool,
}

pub(super) fn generate(
    recipe: &Recipe,
    dims: [usize; 3],
    seed: u64,
    tissue_at: impl Fn([f64; 3]) -> usize + Sync,
) -> Result<Phantom, VolumeError> {
    let source = Path::new(recipe.name);
    let voxel_count = crate::volume::checked_voxel_count(dims, recipe.voxel_type, source)?;
    let spacing_mm: [f64; 3] = std::array::from_fn(|a| recipe.field_of_view_mm[a] / dims[a] as f64);
    let plane = dims[0] * dims[1];
    let mut values = vec![0f32; voxel_count];
    let mut truth = vec![0u8; voxel_count];
    let texture_seed = hash64(seed, 0x7E47);
    values.par_chunks_mut(plane).zip(truth.par_chunks_mut(plane)).enumerate().for_each(|(z, (slice, classes))| {
        for k in 0..plane {
            let (x, y) = (k % dims[0], k / dims[0]);
            let p =
                [(x as f64 + 0.5) * spacing_mm[0], (y as f64 + 0.5) * spacing_mm[1], (z as f64 + 0.5) * spacing_mm[2]];
            let (class, mean, texture) = recipe.tissues[tissue_at(p)];
            let bias = 1.0 + recipe.bias * bias_field(p, recipe.field_of_view_mm);
            classes[k] = class;
            let value = mean + texture * gaussian_from_bits(hash64(texture_seed, (z * plane + k) as u64));
            slice[k] = match recipe.voxel_type {
                VoxelType::I16 => AIR_HU + bias * (value - AIR_HU),
                _ => bias * value,
            };
        }
    });
    for _ in 0..recipe.blur_passes {
        blur_axis(&mut values, dims, 0);
        blur_axis(&mut values, dims, 1);
        blur_axis(&mut values, dims, 2);
    }
    let noise_seed = hash64(seed, 0x0015E);
    let size = recipe.voxel_type.size_bytes();
    let mut bytes = vec![0u8; voxel_count * size];
    let (low, high) = match recipe.voxel_type {
        VoxelType::U8 => (0.0, 255.0),
        VoxelType::I16 => (-1024.0, 3071.0),
        _ => (0.0, 65535.0),
    };
    bytes.par_chunks_mut(plane * size).zip(values.par_chunks(plane)).enumerate().for_each(|(z, (out, slice))| {
        for (k, &value) in slice.iter().enumerate() {
            let noisy = value + recipe.noise * gaussian_from_bits(hash64(noise_seed, (z * plane + k) as u64));
            match recipe.voxel_type {
                // Hounsfield units, clipped as scanners clip them.
                VoxelType::I16 => {
                    let stored = noisy.round().clamp(low, high) as i16;
                    out[2 * k..2 * k + 2].copy_from_slice(&stored.to_le_bytes());
                }
                // A window clips below its floor; magnitude images (MRI) fold the noise there.
                VoxelType::U8 if recipe.windowed => out[k] = noisy.round().clamp(low, high) as u8,
                VoxelType::U8 => out[k] = noisy.abs().round().clamp(low, high) as u8,
                _ => {
                    out[2 * k..2 * k + 2].copy_from_slice(&(noisy.abs().round().clamp(low, high) as u16).to_le_bytes())
                }
            }
        }
    });
    let volume = Volume::new(
        dims,
        spacing_mm,
        recipe.voxel_type,
        ByteOrder::Little,
        ValueScale::IDENTITY,
        VoxelBytes::Owned(bytes),
        source,
    )?;
    Ok(Phantom { volume, truth, class_names: recipe.class_names.to_vec() })
}

/// Air in Hounsfield units: the value a CT bias field leaves alone.
const AIR_HU: f32 = -1000.0;

/// A smooth field in about [-1, 1] over the field of view (a few low-frequency waves).
fn bias_field(p: [f64; 3], field_of_view_mm: [f64; 3]) -> f32 {
    let u: [f64; 3] = std::array::from_fn(|a| p[a] / field_of_view_mm[a]);
    let wave = 0.5 * (std::f64::consts::PI * (u[0] + 0.3 * u[2])).sin() + 0.3 * (2.1 * u[1] + 0.7).cos()
        - 0.2 * (3.0 * u[2] - 1.1).sin();
    wave as f32
}

/// Blurs `values` along `axis` with 1/8 [1 6 1], edges clamped.
fn blur_axis(values: &mut [f32], dims: [usize; 3], axis: usize) {
    let plane = dims[0] * dims[1];
    let stride = [1, dims[0], plane][axis];
    let length = dims[axis];
    if length < 2 {
        return;
    }
    let original = values.to_vec();
    values.par_chunks_mut(plane).enumerate().for_each(|(z, out)| {
        for (k, value) in out.iter_mut().enumerate() {
            let index = z * plane + k;
            let position = [k % dims[0], k / dims[0], z][axis];
            let before = if position == 0 { index } else { index - stride };
            let after = if position + 1 == length { index } else { index + stride };
            *value = (original[before] + 6.0 * original[index] + original[after]) * 0.125;
        }
    });
}

/// Distance in the plane across `axis` from `p` to a curve that runs along `axis` with its
/// centre at `centre(t)` (t = p[axis]); a tube when compared with a radius.
pub(super) fn distance_to_curve(p: [f64; 3], axis: usize, centre: impl Fn(f64) -> [f64; 2]) -> f64 {
    let [a, b] = match axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    };
    let c = centre(p[axis]);
    (p[a] - c[0]).hypot(p[b] - c[1])
}

/// Class ids of [`vessels_ct`].
pub const VESSELS_CLASSES: [&str; 5] = ["air", "soft tissue", "organ", "vessel", "bone"];

/// The 8-bit CT-like abdomen (see the module doc) on `dims` voxels over 160 x 128 x 96 mm.
pub fn vessels_ct(dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
    let recipe = Recipe {
        name: "<vessels CT phantom>",
        class_names: &VESSELS_CLASSES,
        field_of_view_mm: [160.0, 128.0, 96.0],
        voxel_type: VoxelType::U8,
        // The last tissue is marrow: bone by truth, as dark as the organ.
        tissues: &[(0, 8.0, 2.0), (1, 95.0, 6.0), (2, 118.0, 6.0), (3, 185.0, 8.0), (4, 235.0, 8.0), (4, 125.0, 12.0)],
        bias: 0.04,
        noise: 6.0,
        blur_passes: 1,
        windowed: false,
    };
    generate(&recipe, dims, seed, |p| {
        let [x, y, z] = p;
        let body = ((x - 80.0) / 72.0).powi(2) + ((y - 64.0) / 56.0).powi(2);
        if body > 1.0 {
            return 0;
        }
        // Spine: vertebral body, a 1.6 mm cortex around marrow as dark as the organ.
        let spine = (x - 80.0).hypot(y - 98.0);
        if spine < 11.0 {
            return if spine > 9.4 { 4 } else { 5 };
        }
        // Ribs: thin arcs at a few z levels just under the skin.
        for rib_z in [14.0, 38.0, 62.0, 86.0] {
            if (z - rib_z).abs() < 2.6 && (body.sqrt() - 0.9).abs() * 60.0 < 2.4 && y > 40.0 {
                return 4;
            }
        }
        // Aorta in front of the spine, then thin branches through the organ.
        if distance_to_curve(p, 2, |_| [80.0, 78.0]) < 5.0 {
            return 3;
        }
        let branches: [(usize, f64, f64, f64); 5] =
            [(2, 1.8, 40.0, 0.0), (2, 1.4, 56.0, 1.3), (0, 2.2, 30.0, 0.4), (0, 1.2, 52.0, 2.2), (1, 1.6, 34.0, 2.9)];
        for (axis, radius, offset, phase) in branches {
            let d = distance_to_curve(p, axis, |t| {
                let wiggle = 6.0 * (t / 17.0 + phase).sin();
                match axis {
                    2 => [offset + 5.0 * (t / 23.0 + phase).cos(), 50.0 + wiggle],
                    0 => [offset + wiggle, 30.0 + 8.0 * phase + 4.0 * (t / 29.0).cos()],
                    _ => [45.0 + 6.0 * phase + wiggle, 40.0 + 3.0 * (t / 19.0).sin()],
                }
            });
            if d < radius {
                return 3;
            }
        }
        let organ = ((x - 58.0) / 40.0).powi(2) + ((y - 50.0) / 30.0).powi(2) + ((z - 48.0) / 40.0).powi(2);
        if organ < 1.0 {
            return 2;
        }
        1
    })
}

/// Class ids of [`brain_mri`].
pub const BRAIN_CLASSES: [&str; 6] = ["background", "scalp", "skull", "csf", "grey matter", "white matter"];

/// The 16-bit T1-like head (see the module doc) on `dims` voxels over 132 x 156 x 120 mm.
pub fn brain_mri(dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
    let recipe = Recipe {
        name: "<brain MRI phantom>",
        class_names: &BRAIN_CLASSES,
        field_of_view_mm: [132.0, 156.0, 120.0],
        voxel_type: VoxelType::U16,
        tissues: &[
            (0, 0.0, 0.0),
            (1, 2400.0, 150.0),
            (2, 350.0, 60.0),
            (3, 650.0, 60.0),
            (4, 1350.0, 80.0),
            (5, 1950.0, 70.0),
        ],
        bias: 0.15,
        noise: 70.0,
        blur_passes: 1,
        windowed: false,
    };
    generate(&recipe, dims, seed, |p| {
        let q = [(p[0] - 66.0) / 58.0, (p[1] - 78.0) / 70.0, (p[2] - 60.0) / 52.0];
        let rho = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        if rho >= 1.0 {
            return 0;
        }
        // Depth below the scalp surface, mm (an ellipsoidal approximation).
        let depth = (1.0 - rho) * 58.0;
        if depth < 4.0 {
            return 1;
        }
        if depth < 9.0 {
            return 2;
        }
        if depth < 11.0 {
            return 3;
        }
        // Gyri: the grey/white boundary folds 2.5-4.5 mm deep, sulci add CSF clefts.
        let (theta, phi) = (q[2].atan2(q[0].hypot(q[1])), q[1].atan2(q[0]));
        let fold = (7.0 * phi).sin() * (6.0 * theta).cos();
        let white_depth = 14.5 + 1.0 * fold;
        if fold > 0.75 && depth < 11.0 + 3.0 * (fold - 0.75) / 0.25 {
            return 3;
        }
        let ventricle =
            |cx: f64| ((p[0] - cx) / 5.0).powi(2) + ((p[1] - 74.0) / 18.0).powi(2) + ((p[2] - 62.0) / 9.0).powi(2);
        if ventricle(59.0) < 1.0 || ventricle(73.0) < 1.0 {
            return 3;
        }
        if depth < white_depth { 4 } else { 5 }
    })
}

/// Class ids of [`shells_mri`].
pub const SHELLS_CLASSES: [&str; 6] = ["background", "rind", "flesh", "membrane", "core", "seed"];

/// The 8-bit MRI-like nested shells (see the module doc) on `dims` voxels over 112 x 112 x 96
/// mm.
pub fn shells_mri(dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
    let recipe = Recipe {
        name: "<shells MRI phantom>",
        class_names: &SHELLS_CLASSES,
        field_of_view_mm: [112.0, 112.0, 96.0],
        voxel_type: VoxelType::U8,
        tissues: &[(0, 6.0, 0.0), (1, 200.0, 10.0), (2, 105.0, 10.0), (3, 165.0, 8.0), (4, 50.0, 8.0), (5, 205.0, 8.0)],
        bias: 0.12,
        noise: 7.0,
        blur_passes: 1,
        windowed: false,
    };
    generate(&recipe, dims, seed, |p| {
        let q = [(p[0] - 56.0) / 50.0, (p[1] - 56.0) / 46.0, (p[2] - 48.0) / 42.0];
        let rho = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        let depth = (1.0 - rho) * 46.0;
        if depth <= 0.0 {
            return 0;
        }
        if depth < 2.2 {
            return 1;
        }
        // Seeds: small spheres in the flesh, as bright as the rind.
        for k in 0..10 {
            let angle = k as f64 * 0.628;
            let centre = [56.0 + 28.0 * angle.cos(), 56.0 + 26.0 * angle.sin(), 48.0 + 14.0 * (2.0 * angle).sin()];
            if (p[0] - centre[0]).hypot(p[1] - centre[1]).hypot(p[2] - centre[2]) < 3.0 {
                return 5;
            }
        }
        if depth < 24.0 {
            return 2;
        }
        if depth < 26.0 {
            return 3;
        }
        4
    })
}
