//! Two more phantoms for the accuracy harness, with bodies the volume's faces cut and air
//! around them, and geometry, noise and bias that change with the seed (so that seeds kept for
//! checking differ from the tuning seeds in more than noise):
//!
//! * [`torso_ct`]: 16-bit CT in Hounsfield units, a chest-abdomen slab. Air around a body
//!   that runs through both z faces and rests on the y face (a table's side); soft tissue (fat
//!   under the skin, muscle), a large liver, contrast-filled vessels (an aorta and thin hepatic
//!   branches 0.8-2 mm in radius), bone (a spine with cortex and marrow, thin ribs) and the
//!   lungs (air inside the body, cut by the top face).
//! * [`head_mri`]: 8-bit T1-like head on a neck that the bottom face cuts. Background, scalp
//!   (bright fat), skull (dark), CSF, brain and neck muscle; the sinuses are air inside the
//!   head (background by truth). A strong bias field.
//! * [`chest_ct_windowed`]: 8-bit chest CT as a mediastinal window stores it (level 40, width
//!   400 HU): the lungs are as black as the air around the body, and they leave the volume
//!   through its top face (their apices and the trachea). Air, fat under the skin, soft tissue
//!   (muscle, heart and mediastinum), lungs with their vessels, bone (spine and ribs).
//!
//! Built with [`super::procedural`]'s recipe (texture, bias, blur, noise). Never: reads files.

use super::Phantom;
use super::procedural::{Recipe, distance_to_curve, generate};
use crate::rng::{hash64, unit_f64};
use crate::volume::{VolumeError, VoxelType};

/// Class ids of [`torso_ct`].
pub const TORSO_CLASSES: [&str; 6] = ["air", "soft tissue", "liver", "vessel", "bone", "lung"];

/// A number in `low..high` drawn from `seed` and `key`.
fn drawn(seed: u64, key: u64, low: f64, high: f64) -> f64 {
    low + (high - low) * unit_f64(hash64(hash64(seed, 0xB0D1E5), key))
}

/// The 16-bit CT torso (see the module doc) on `dims` voxels over 200 x 160 x 120 mm.
pub fn torso_ct(dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
    let shift = [drawn(seed, 1, -8.0, 8.0), drawn(seed, 2, -6.0, 6.0)];
    let liver_radii = [drawn(seed, 3, 42.0, 52.0), drawn(seed, 4, 32.0, 40.0), drawn(seed, 5, 40.0, 55.0)];
    let phase = drawn(seed, 6, 0.0, std::f64::consts::TAU);
    let recipe = Recipe {
        name: "<torso CT phantom>",
        class_names: &TORSO_CLASSES,
        field_of_view_mm: [200.0, 160.0, 120.0],
        voxel_type: VoxelType::I16,
        tissues: &[
            (0, -1000.0, 5.0),
            (1, 45.0, 10.0),
            (2, 95.0, 8.0),
            (3, 240.0, 12.0),
            (4, 900.0, 60.0),
            (5, -840.0, 30.0),
            // Fat under the skin, soft tissue by truth; marrow, bone by truth.
            (1, -95.0, 10.0),
            (4, 230.0, 40.0),
        ],
        bias: drawn(seed, 7, 0.0, 0.06) as f32,
        noise: drawn(seed, 8, 10.0, 25.0) as f32,
        blur_passes: 1,
        windowed: false,
    };
    generate(&recipe, dims, seed, |p| {
        let [x, y, z] = p;
        // The body: an ellipse that the y = 160 face cuts (the back on the table's side).
        let body = ((x - 100.0 - shift[0]) / 90.0).powi(2) + ((y - 96.0 - shift[1]) / 68.0).powi(2);
        if body > 1.0 {
            return 0;
        }
        let skin_depth = (1.0 - body.sqrt()) * 68.0;
        if skin_depth < 5.0 {
            return 6;
        }
        // Spine near the back: cortex around marrow.
        let spine = (x - 100.0 - shift[0]).hypot(y - 132.0 - shift[1]);
        if spine < 13.0 {
            return if spine > 11.0 { 4 } else { 7 };
        }
        // Ribs: thin arcs under the fat at a few z levels.
        for rib_z in [12.0, 36.0, 60.0, 84.0, 108.0] {
            if (z - rib_z - 4.0 * phase.sin()).abs() < 2.5 && (7.0..11.0).contains(&skin_depth) {
                return 4;
            }
        }
        // Aorta beside the spine, then thin branches through the liver.
        if distance_to_curve(p, 2, |_| [88.0 + shift[0], 112.0 + shift[1]]) < 10.0 {
            return 3;
        }
        let liver = [62.0 + shift[0], 80.0 + shift[1], 40.0];
        let in_liver = ((x - liver[0]) / liver_radii[0]).powi(2)
            + ((y - liver[1]) / liver_radii[1]).powi(2)
            + ((z - liver[2]) / liver_radii[2]).powi(2)
            < 1.0;
        // The lungs: the top of the slab, cut by the z = 120 face.
        for side in [-1.0, 1.0] {
            let lung = ((x - 100.0 - shift[0] - side * 42.0) / 30.0).powi(2) + ((y - 92.0 - shift[1]) / 38.0).powi(2);
            if lung < 1.0 && z > 78.0 + 10.0 * lung && !in_liver {
                return 5;
            }
        }
        if in_liver {
            let branches: [(usize, f64, f64); 4] = [(2, 2.0, 0.0), (2, 1.2, 1.7), (0, 1.5, 0.6), (1, 0.9, 2.4)];
            for (axis, radius, offset) in branches {
                let d = distance_to_curve(p, axis, |t| {
                    let wiggle = 7.0 * (t / 15.0 + phase + offset).sin();
                    match axis {
                        2 => [liver[0] - 15.0 + 12.0 * offset + wiggle, liver[1] + 5.0 * (t / 21.0 + offset).cos()],
                        0 => [liver[1] - 8.0 + 6.0 * offset + wiggle, liver[2] + 9.0 * (t / 27.0).cos()],
                        _ => [liver[0] + 10.0 * offset - 12.0 + wiggle, liver[2] - 6.0 + 4.0 * (t / 19.0).sin()],
                    }
                });
                if d < radius {
                    return 3;
                }
            }
            return 2;
        }
        1
    })
}

/// Class ids of [`head_mri`].
pub const HEAD_CLASSES: [&str; 6] = ["background", "scalp", "skull", "csf", "brain", "neck"];

/// The 8-bit T1-like head on a cut neck (see the module doc) on `dims` voxels over
/// 150 x 180 x 170 mm.
pub fn head_mri(dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
    let centre = [75.0 + drawn(seed, 1, -6.0, 6.0), 92.0 + drawn(seed, 2, -6.0, 6.0), 100.0];
    let radii = [drawn(seed, 3, 56.0, 64.0), drawn(seed, 4, 70.0, 80.0), drawn(seed, 5, 58.0, 64.0)];
    let recipe = Recipe {
        name: "<head MRI phantom>",
        class_names: &HEAD_CLASSES,
        field_of_view_mm: [150.0, 180.0, 170.0],
        voxel_type: VoxelType::U8,
        tissues: &[(0, 3.0, 0.0), (1, 210.0, 12.0), (2, 25.0, 6.0), (3, 45.0, 8.0), (4, 120.0, 10.0), (5, 90.0, 9.0)],
        bias: drawn(seed, 6, 0.15, 0.4) as f32,
        noise: drawn(seed, 7, 4.0, 9.0) as f32,
        blur_passes: 1,
        windowed: false,
    };
    generate(&recipe, dims, seed, |p| {
        let [x, y, z] = p;
        let q = [(x - centre[0]) / radii[0], (y - centre[1]) / radii[1], (z - centre[2]) / radii[2]];
        let rho = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        // The neck: a cylinder from the head down through the z = 0 face.
        let neck = ((x - centre[0]) / 32.0).hypot((y - centre[1] - 10.0) / 36.0);
        if rho >= 1.0 {
            if neck < 1.0 && z < centre[2] {
                return if neck > 0.86 { 1 } else { 5 };
            }
            return 0;
        }
        let depth = (1.0 - rho) * radii[0];
        if depth < 5.0 {
            return 1;
        }
        // Sinuses: air behind the face, inside the skull's front.
        let sinus = ((x - centre[0]) / 14.0).powi(2)
            + ((y - centre[1] + 0.78 * radii[1]) / 8.0).powi(2)
            + ((z - centre[2] + 8.0) / 10.0).powi(2);
        if sinus < 1.0 {
            return 0;
        }
        if depth < 11.0 {
            return 2;
        }
        if depth < 13.5 {
            return 3;
        }
        let ventricle =
            ((x - centre[0]).abs() - 7.0).hypot((y - centre[1]) / 3.0) / 6.0 + ((z - centre[2]) / 14.0).powi(2);
        if ventricle < 1.0 {
            return 3;
        }
        4
    })
}

/// Class ids of [`chest_ct_windowed`].
pub const CHEST_CLASSES: [&str; 5] = ["air", "fat", "soft tissue", "lung", "bone"];

/// The windowed 8-bit chest CT (see the module doc) on `dims` voxels over 320 x 250 x 160 mm,
/// the body along z.
pub fn chest_ct_windowed(dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
    let shift = [drawn(seed, 1, -6.0, 6.0), drawn(seed, 2, -5.0, 5.0)];
    let lung_radii = [drawn(seed, 3, 46.0, 54.0), drawn(seed, 4, 62.0, 72.0)];
    let recipe = Recipe {
        name: "<windowed chest CT phantom>",
        class_names: &CHEST_CLASSES,
        field_of_view_mm: [320.0, 250.0, 160.0],
        voxel_type: VoxelType::U8,
        // Air and lung far below the window (-1000 and -850 HU: clipped to 0), fat (-100 HU)
        // 38, soft tissue (40 HU) 128, bone above the window; the last is a lung vessel, lung
        // by truth, as bright as soft tissue.
        tissues: &[
            (0, -400.0, 0.0),
            (1, 38.0, 6.0),
            (2, 128.0, 8.0),
            (3, -300.0, 0.0),
            (4, 400.0, 0.0),
            (3, 120.0, 8.0),
        ],
        bias: 0.0,
        noise: drawn(seed, 5, 4.0, 8.0) as f32,
        blur_passes: 1,
        windowed: true,
    };
    let centre = [160.0 + shift[0], 125.0 + shift[1]];
    generate(&recipe, dims, seed, |p| {
        let [x, y, z] = p;
        let ring = |a: f64, b: f64| ((x - centre[0]) / a).hypot((y - centre[1]) / b);
        if ring(145.0, 100.0) >= 1.0 {
            return 0;
        }
        if ring(133.0, 88.0) >= 1.0 {
            return 1;
        }
        // Spine behind the heart, ribs on the cage at a few heights.
        if (x - centre[0]).hypot(y - centre[1] - 68.0) < 20.0 {
            return 4;
        }
        let cage = ring(122.0, 78.0);
        if (cage - 0.97).abs() < 0.03 && ((z / 22.0).fract() - 0.5).abs() < 0.2 {
            return 4;
        }
        // The trachea from the top face down to the lungs' roots.
        if z > 100.0 && (x - centre[0]).hypot(y - centre[1] + 30.0) < 9.0 {
            return 3;
        }
        if cage < 0.94 {
            for side in [-1.0, 1.0] {
                let lung = ((x - centre[0] - side * 62.0) / lung_radii[0]).powi(2)
                    + ((y - centre[1] + 6.0) / lung_radii[1]).powi(2)
                    + ((z - 170.0) / 200.0).powi(2);
                if lung < 1.0 && z > 8.0 {
                    let vessel =
                        distance_to_curve(p, 0, |t| [centre[1] - 6.0 + 20.0 * (t / 31.0).sin(), 60.0 + side * 25.0]);
                    return if vessel < 3.0 { 5 } else { 3 };
                }
            }
        }
        2
    })
}
