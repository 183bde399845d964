//! Default opacities that let every class be seen ("see-through"), beside the paper's eq. 9
//! (§3.5), which stays available as [`OpacityRule::Paper`].
//!
//! Why a second rule: eq. 9 orders classes by spatial variance, which says little about which
//! class stands in front of which. On the engine with its benchmark lassos both classes have a
//! variance of about 0.09; eq. 9 made the outer one opaque (0.6 to 1) and the class it wraps
//! could not be seen at all. What hides a class is another class that wraps it and faces the
//! viewer, and how much it hides depends on how thick its walls are along a ray.
//!
//! The rule, from one pass over the labels ([`class_surfaces`]), for class `i` with volume
//! `V_i` (mm³), surface area `S_i` (mm², faces of its voxels that touch another label, the
//! background, or the edge of the volume or clip box) and contact areas `C_ij` (the part of
//! `S_i` facing label `j`, `j = 0` being background and everything outside):
//!
//! 1. **Wall thickness**: the mean chord length `l_i = 4 V_i / S_i` (Cauchy's formula: the mean
//!    length of a random line's intersection with a body is 4 volume / surface area), in mm.
//! 2. **Occlusion**: `s_i = e_i h_i` with exposure `e_i = C_i0 / S_i` (how much of the class
//!    faces the outside, i.e. the viewer) and cover `h_i = max_j C_ij / S_j` over the other
//!    classes `j` (the largest share of another class's surface that class `i` wraps). A class
//!    that wraps nothing, or that is itself wrapped, has `s` near 0.
//! 3. **Opacity per wall**: a ray crossing one mean chord of class `i` accumulates
//!    `A_i = A_wrapped - (A_wrapped - A_wrapping) s_i / max_j s_j` (so the strongest occluder
//!    lets [`SEE_THROUGH_WRAPPING`] through and classes that hide nothing are nearly opaque,
//!    [`SEE_THROUGH_WRAPPED`]).
//! 4. **Per sample**: opacity is defined per reference step `r` (the smallest voxel spacing, as
//!    the renderer corrects it), so `o_i = 1 - (1 - A_i)^(r / l_i)`: thick classes get a lower
//!    opacity per step, thin shells a higher one, and both reach `A_i` across a wall.
//! 5. **Edges**: eq. 9's boundary factor `(1 + F_v)` stays, and grows with occlusion to
//!    `(1 + (1 + s_i / max s) F_v)`: the surfaces of the classes in front are drawn up to three
//!    times as opaque as their insides, so their shape still reads while what they wrap shows
//!    through (gradient-magnitude edge emphasis, Levoy 1988; Rheingans & Ebert 2001).
//!
//! Entry points: [`class_surfaces`] (the statistics, for the volume or a clip box) and
//! [`see_through_opacities`] (the opacity line of each class, `[at F_v = 0, at F_v = 1]`).
//!
//! Never: picks colours, renders, or reads the scalar volume.

use super::TransferError;
use super::harmony::{ClipBox, check_labels};
use crate::volume::Volume;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Which rule sets the default opacity of each class.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OpacityRule {
    /// Opacity falls with occlusion and is normalised by wall thickness (the module doc).
    #[default]
    SeeThrough,
    /// The paper's eq. 9 rescaled into [0.2, 1] (`harmony`).
    Paper,
}

/// Opacity accumulated across one mean chord of the class that occludes most.
pub const SEE_THROUGH_WRAPPING: f64 = 0.3;
/// Opacity accumulated across one mean chord of a class that occludes nothing.
pub const SEE_THROUGH_WRAPPED: f64 = 0.9;

/// What the see-through rule needs of one class: its size and whom it touches.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ClassSurface {
    /// The class's volume: its voxel count times the voxel volume, in mm³.
    pub volume_mm3: f64,
    /// Area of the faces between the class's voxels and any other label or the outside.
    pub surface_area_mm2: f64,
    /// `contact_area_mm2[j]`: the part facing label `j` (0: background or outside the box).
    pub contact_area_mm2: Vec<f64>,
}

impl ClassSurface {
    /// Cauchy's mean chord length `4 V / S` in mm (0 for an empty class).
    pub fn mean_chord_mm(&self) -> f64 {
        if self.surface_area_mm2 > 0.0 { 4.0 * self.volume_mm3 / self.surface_area_mm2 } else { 0.0 }
    }

    /// The share of the surface facing background or the outside.
    pub fn exposure(&self) -> f64 {
        if self.surface_area_mm2 > 0.0 { self.contact_area_mm2[0] / self.surface_area_mm2 } else { 0.0 }
    }
}

/// Per-class surfaces (class `k` at index `k - 1`) of the labelled voxels inside `clip`;
/// neighbours outside the box count as outside. One parallel pass over z.
pub fn class_surfaces(
    volume: &Volume,
    labels: &[u8],
    class_count: usize,
    clip: ClipBox,
) -> Result<Vec<ClassSurface>, TransferError> {
    check_labels(volume, labels, class_count)?;
    let (dims, spacing_mm) = (volume.dims, volume.spacing_mm);
    let clip = clip.check(dims)?;
    let labels_per_class = class_count + 1;
    let [size_x, size_y, _] = dims;
    let plane = size_x * size_y;
    // counts[(k * labels_per_class + j) * 3 + axis]: faces normal to `axis` between k and j;
    // counts[voxels_at + k]: voxels of class k.
    let voxels_at = labels_per_class * labels_per_class * 3;
    let counts = (clip.lo[2]..=clip.hi[2])
        .into_par_iter()
        .fold(
            || vec![0u64; voxels_at + labels_per_class],
            |mut counts, z| {
                for y in clip.lo[1]..=clip.hi[1] {
                    let row = z * plane + y * size_x;
                    for x in clip.lo[0]..=clip.hi[0] {
                        let label = labels[row + x] as usize;
                        // check_labels guarantees label <= class_count.
                        if label == 0 {
                            continue;
                        }
                        counts[voxels_at + label] += 1;
                        let voxel = [x, y, z];
                        let stride = [1, size_x, plane];
                        for axis in 0..3 {
                            let index = row + x;
                            let before = (voxel[axis] > clip.lo[axis]).then(|| labels[index - stride[axis]] as usize);
                            let after = (voxel[axis] < clip.hi[axis]).then(|| labels[index + stride[axis]] as usize);
                            for neighbour in [before, after] {
                                let neighbour = neighbour.unwrap_or(0);
                                if neighbour != label {
                                    counts[(label * labels_per_class + neighbour) * 3 + axis] += 1;
                                }
                            }
                        }
                    }
                }
                counts
            },
        )
        .reduce(
            || vec![0u64; voxels_at + labels_per_class],
            |mut sum, part| {
                sum.iter_mut().zip(part).for_each(|(s, p)| *s += p);
                sum
            },
        );
    let face_area_mm2 = [spacing_mm[1] * spacing_mm[2], spacing_mm[0] * spacing_mm[2], spacing_mm[0] * spacing_mm[1]];
    let voxel_volume_mm3 = spacing_mm.iter().product::<f64>();
    Ok((1..=class_count)
        .map(|class| {
            let contact_area_mm2: Vec<f64> = (0..labels_per_class)
                .map(|j| (0..3).map(|a| counts[(class * labels_per_class + j) * 3 + a] as f64 * face_area_mm2[a]).sum())
                .collect();
            ClassSurface {
                volume_mm3: counts[voxels_at + class] as f64 * voxel_volume_mm3,
                surface_area_mm2: contact_area_mm2.iter().sum(),
                contact_area_mm2,
            }
        })
        .collect())
}

/// The occlusion `s_i` of each class (step 2 of the module doc).
pub fn occlusion(surfaces: &[ClassSurface]) -> Vec<f64> {
    surfaces
        .iter()
        .enumerate()
        .map(|(i, surface)| {
            let cover = surfaces
                .iter()
                .enumerate()
                .filter(|(j, other)| *j != i && other.surface_area_mm2 > 0.0)
                .map(|(_, other)| other.contact_area_mm2[i + 1] / other.surface_area_mm2)
                .fold(0.0, f64::max);
            surface.exposure() * cover
        })
        .collect()
}

/// Each class's opacity line `[at F_v = 0, at F_v = 1]` under the see-through rule, for a
/// renderer whose reference step is `reference_step_mm` (the smallest voxel spacing).
pub fn see_through_opacities(surfaces: &[ClassSurface], reference_step_mm: f64) -> Vec<[f32; 2]> {
    let occlusion = occlusion(surfaces);
    let strongest = occlusion.iter().copied().fold(0.0, f64::max);
    surfaces
        .iter()
        .zip(&occlusion)
        .map(|(surface, &s)| {
            let relative = if strongest > 0.0 { s / strongest } else { 0.0 };
            let per_wall = SEE_THROUGH_WRAPPED - (SEE_THROUGH_WRAPPED - SEE_THROUGH_WRAPPING) * relative;
            // A class thinner than one step reaches its wall opacity in one step.
            let steps_per_wall = (surface.mean_chord_mm() / reference_step_mm).max(1.0);
            let inside = 1.0 - (1.0 - per_wall).powf(1.0 / steps_per_wall);
            let edge = (inside * (2.0 + relative)).min(1.0);
            [inside as f32, edge as f32]
        })
        .collect()
}

#[cfg(test)]
#[path = "opacity_tests.rs"]
mod tests;
