//! Patient orientation: where in the patient each voxel axis of a [`Volume`](super::Volume)
//! points, as the file says, in DICOM's patient frame.
//!
//! The frame is LPS (DICOM PS3.3 C.7.6.2.1.1): +x toward the patient's Left, +y toward
//! Posterior, +z toward Superior (head); right-handed. A [`PatientOrientation`] holds the unit
//! direction in LPS in which each voxel axis x, y, z increases: the columns of the
//! `patient_from_voxel` direction matrix. Spacing stays in `Volume::spacing_mm`, so the
//! patient position of voxel (i, j, k) is `origin + i·dx·d_x + j·dy·d_y + k·dz·d_z`.
//!
//! How each format says it (parsed in `formats.rs`, one function per format):
//! * DICOM: ImageOrientationPatient's row cosines r (along a row, increasing column: x) and
//!   column cosines c (down a column: y), already in LPS; z is the slice normal r × c, because
//!   the reader orders slices by ascending position along it. A tilted series resampled onto a
//!   regular grid keeps these axes (its grid is built along r, c and r × c), so the GE head
//!   with 18.5° gantry tilt stays oblique: y leans 18.5° from posterior toward inferior.
//! * NIfTI-1: the sform (`srow_*`) when `sform_code` > 0, else the qform (quaternion, `qfac` in
//!   `pixdim[0]`, `qoffset_*`) when `qform_code` > 0, else nothing: the order nibabel's
//!   `get_best_affine` uses (nibabel takes any non-zero code; negative codes are not defined by
//!   the standard and are treated as unset here). NIfTI's world is RAS+, so x and y flip sign
//!   into LPS (nibabel's "Coordinate systems and affines").
//! * NRRD: `space` names the frame of `space directions` and `space origin` (teem's format
//!   definition, section 4): `left-posterior-superior` is LPS as is, `right-anterior-superior`
//!   and `left-anterior-superior` flip x and y or only y (the `-time` variants and the
//!   abbreviations `LPS`, `RAS`, `LAS`, ... likewise). `scanner-xyz`, `3D-right-handed` and a
//!   bare `space dimension` carry no anatomical meaning: no orientation. 3D Slicer writes LPS
//!   files and shows RAS, the same flip.
//! * MetaImage: ITK writes `TransformMatrix` as each axis's direction in turn (the first three
//!   numbers are axis x's direction), in ITK's LPS world, and `Offset` as the origin; without a
//!   `TransformMatrix`, `AnatomicalOrientation` gives ITK's three "from" letters (`RAI` = x
//!   runs from Right to left, y from Anterior to posterior, z from Inferior to superior: LPS,
//!   the opposite of DICOM's "toward" letters).
//!
//! Oblique axes get the *nearest* patient direction ([`PatientOrientation::anatomical_axes`]):
//! the assignment of the three patient axes to the three voxel axes, one each, that aligns them
//! best, so two voxel axes never share a letter.
//!
//! Never: reorders, resamples or rotates voxels (the grid stays as stored), or fails a read:
//! a missing, unknown or degenerate orientation is `None` (with a warning for the latter two).

mod formats;
#[cfg(test)]
mod tests;

pub use formats::{NiftiTransform, from_dicom, from_metaimage, from_nifti, from_nrrd, nrrd_space_fields};

/// The smallest |determinant| of the unit direction matrix accepted: below it two voxel axes
/// are within a few degrees of parallel, which no scanner produces.
const MIN_DETERMINANT: f64 = 1e-2;

/// A patient direction, named by DICOM's letter for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PatientDirection {
    /// Towards the patient's left (`L`).
    Left,
    /// Towards the patient's right (`R`).
    Right,
    /// Towards the patient's back (`P`).
    Posterior,
    /// Towards the patient's front (`A`).
    Anterior,
    /// Towards the patient's head (`S`).
    Superior,
    /// Towards the patient's feet (`I`).
    Inferior,
}

impl PatientDirection {
    /// DICOM's letter: "L", "R", "P", "A", "S", "I".
    pub fn letter(self) -> &'static str {
        match self {
            PatientDirection::Left => "L",
            PatientDirection::Right => "R",
            PatientDirection::Posterior => "P",
            PatientDirection::Anterior => "A",
            PatientDirection::Superior => "S",
            PatientDirection::Inferior => "I",
        }
    }

    /// The direction pointing the other way.
    pub fn opposite(self) -> PatientDirection {
        match self {
            PatientDirection::Left => PatientDirection::Right,
            PatientDirection::Right => PatientDirection::Left,
            PatientDirection::Posterior => PatientDirection::Anterior,
            PatientDirection::Anterior => PatientDirection::Posterior,
            PatientDirection::Superior => PatientDirection::Inferior,
            PatientDirection::Inferior => PatientDirection::Superior,
        }
    }

    /// The LPS axis (0 left-right, 1 posterior-anterior, 2 superior-inferior) and whether this
    /// direction is its positive end (L, P, S).
    pub fn lps_axis(self) -> (usize, bool) {
        match self {
            PatientDirection::Left => (0, true),
            PatientDirection::Right => (0, false),
            PatientDirection::Posterior => (1, true),
            PatientDirection::Anterior => (1, false),
            PatientDirection::Superior => (2, true),
            PatientDirection::Inferior => (2, false),
        }
    }

    /// The direction along LPS axis `axis` (0..3), positive (L, P, S) or not.
    pub fn from_lps_axis(axis: usize, positive: bool) -> PatientDirection {
        match (axis, positive) {
            (0, true) => PatientDirection::Left,
            (0, false) => PatientDirection::Right,
            (1, true) => PatientDirection::Posterior,
            (1, false) => PatientDirection::Anterior,
            (_, true) => PatientDirection::Superior,
            (_, false) => PatientDirection::Inferior,
        }
    }

    /// The unit vector of this direction in LPS.
    pub fn lps_vector(self) -> [f64; 3] {
        let (axis, positive) = self.lps_axis();
        let mut vector = [0.0; 3];
        vector[axis] = if positive { 1.0 } else { -1.0 };
        vector
    }
}

/// Where a volume's voxel axes point in the patient (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatientOrientation {
    /// `axis_directions_lps[a]`: the unit vector in LPS along which voxel axis `a` (x, y, z)
    /// increases.
    axis_directions_lps: [[f64; 3]; 3],
    /// The LPS position in mm of the centre of voxel (0, 0, 0), when the file gives it.
    pub origin_lps_mm: Option<[f64; 3]>,
}

impl PatientOrientation {
    /// An orientation from the direction of each voxel axis in LPS (any length, normalised
    /// here) and the origin. `None` when a direction is not finite, has no length, or two are
    /// (nearly) parallel; a non-finite origin is dropped.
    pub fn new(axis_directions_lps: [[f64; 3]; 3], origin_lps_mm: Option<[f64; 3]>) -> Option<PatientOrientation> {
        let mut unit = [[0.0; 3]; 3];
        for (out, direction) in unit.iter_mut().zip(&axis_directions_lps) {
            let length = norm(*direction);
            if !(length.is_finite() && length > 0.0) {
                return None;
            }
            *out = direction.map(|c| c / length);
        }
        let determinant = determinant(unit).abs();
        if determinant.is_nan() || determinant < MIN_DETERMINANT {
            return None;
        }
        let origin_lps_mm = origin_lps_mm.filter(|o| o.iter().all(|c| c.is_finite()));
        Some(PatientOrientation { axis_directions_lps: unit, origin_lps_mm })
    }

    /// As [`PatientOrientation::new`], from directions and origin in RAS (NIfTI's world).
    pub fn from_ras(axis_directions_ras: [[f64; 3]; 3], origin_ras_mm: Option<[f64; 3]>) -> Option<PatientOrientation> {
        let flip = |v: [f64; 3]| [-v[0], -v[1], v[2]];
        PatientOrientation::new(axis_directions_ras.map(flip), origin_ras_mm.map(flip))
    }

    /// The unit direction in LPS of voxel axis `axis` (0, 1, 2 for x, y, z; larger is z).
    pub fn axis_direction_lps(&self, axis: usize) -> [f64; 3] {
        self.axis_directions_lps[axis.min(2)]
    }

    /// All three unit directions, x, y, z.
    pub fn axis_directions_lps(&self) -> [[f64; 3]; 3] {
        self.axis_directions_lps
    }

    /// The patient direction each voxel axis increases toward, nearest for oblique axes: of
    /// the six ways to give each voxel axis its own patient axis, the one whose direction
    /// cosines have the largest sum of magnitudes (ties: the first in x, y, z order), so two
    /// voxel axes never get the same letter.
    pub fn anatomical_axes(&self) -> [PatientDirection; 3] {
        const PERMUTATIONS: [[usize; 3]; 6] = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
        let d = &self.axis_directions_lps;
        let score = |p: &[usize; 3]| (0..3).map(|a| d[a][p[a]].abs()).sum::<f64>();
        let mut best = PERMUTATIONS[0];
        for permutation in &PERMUTATIONS[1..] {
            if score(permutation) > score(&best) + 1e-12 {
                best = *permutation;
            }
        }
        std::array::from_fn(|a| PatientDirection::from_lps_axis(best[a], d[a][best[a]] >= 0.0))
    }

    /// DICOM's letters of [`PatientOrientation::anatomical_axes`], e.g. `["L", "P", "S"]`.
    pub fn anatomical_letters(&self) -> [&'static str; 3] {
        self.anatomical_axes().map(PatientDirection::letter)
    }

    /// The voxel axis whose nearest patient axis is that of `direction` (left-right,
    /// posterior-anterior or superior-inferior), and whether the voxel axis increases toward
    /// `direction` (`true`) or away from it.
    pub fn voxel_axis_toward(&self, direction: PatientDirection) -> (usize, bool) {
        let axes = self.anatomical_axes();
        let wanted = direction.lps_axis().0;
        let axis = axes.iter().position(|d| d.lps_axis().0 == wanted).unwrap_or(wanted);
        (axis, axes[axis] == direction)
    }

    /// `direction_lps` (a patient direction) expressed along the voxel axes: the components
    /// `v` with `Σ v[a] · d_a = direction_lps`, where `d_a` are the unit axis directions (so
    /// these are millimetres along each axis, not voxels). The 3-D view uses it to find where
    /// the patient's front and top are in the volume's box.
    pub fn voxel_frame_from_patient(&self, direction_lps: [f64; 3]) -> [f64; 3] {
        // Cramer's rule on the columns d_x, d_y, d_z; `new` ensured the determinant is not small.
        let [dx, dy, dz] = self.axis_directions_lps;
        let det = determinant(self.axis_directions_lps);
        [
            determinant([direction_lps, dy, dz]) / det,
            determinant([dx, direction_lps, dz]) / det,
            determinant([dx, dy, direction_lps]) / det,
        ]
    }

    /// True when the voxel axes form a right-handed frame in the patient (x × y points along
    /// +z's side). A left-handed volume (common in NIfTI: x toward the right, `LAS` stored
    /// flipped) shown without flipping an axis is a mirror image of the patient.
    pub fn is_right_handed(&self) -> bool {
        determinant(self.axis_directions_lps) > 0.0
    }
}

/// The determinant of the matrix whose columns are `columns`.
fn determinant(columns: [[f64; 3]; 3]) -> f64 {
    let [a, b, c] = columns;
    a[0] * (b[1] * c[2] - b[2] * c[1]) - b[0] * (a[1] * c[2] - a[2] * c[1]) + c[0] * (a[1] * b[2] - a[2] * b[1])
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
