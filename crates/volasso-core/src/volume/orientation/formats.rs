//! Each format's way of saying where the voxel axes point, turned into a
//! [`PatientOrientation`] (conventions in the parent module's doc), and the NRRD fields that
//! write one back.
//!
//! Every function here returns `None` when the file does not say, and also when what it says
//! cannot be used (a degenerate matrix, an unknown space name): then with a warning naming the
//! file, because the volume itself is still good and opens without orientation.

use super::{PatientOrientation, cross};
use std::path::Path;

/// DICOM: ImageOrientationPatient (row cosines, then column cosines) and the ImagePositionPatient
/// of voxel (0, 0, 0). Volume axes are the row direction, the column direction and their cross
/// product, the order the series reader stacks slices in.
pub fn from_dicom(
    image_orientation: [f64; 6],
    first_voxel_lps_mm: Option<[f64; 3]>,
    path: &Path,
) -> Option<PatientOrientation> {
    let row = [image_orientation[0], image_orientation[1], image_orientation[2]];
    let column = [image_orientation[3], image_orientation[4], image_orientation[5]];
    let orientation = PatientOrientation::new([row, column, cross(row, column)], first_voxel_lps_mm);
    if orientation.is_none() {
        log::warn!(
            "{}: ImageOrientationPatient {image_orientation:?} is degenerate; orientation unknown",
            path.display()
        );
    }
    orientation
}

/// The NIfTI-1 header fields that place the grid in the world (RAS+, millimetres).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NiftiTransform {
    /// `qform_code`: what the quaternion transform maps to; 0 means unused.
    pub qform_code: i16,
    /// `sform_code`: what the affine `srow_*` transform maps to; 0 means unused.
    pub sform_code: i16,
    /// `quatern_b`, `quatern_c`, `quatern_d`.
    pub quaternion_bcd: [f64; 3],
    /// `qoffset_x`, `qoffset_y`, `qoffset_z`.
    pub qoffset_mm: [f64; 3],
    /// `pixdim[0]`: -1 flips the third axis of the qform; any other value means 1.
    pub qfac: f64,
    /// `srow_x`, `srow_y`, `srow_z`.
    pub srow: [[f64; 4]; 3],
}

/// NIfTI: the sform when `sform_code` > 0, else the qform when `qform_code` > 0, else `None`.
pub fn from_nifti(transform: &NiftiTransform, path: &Path) -> Option<PatientOrientation> {
    let (which, orientation) = if transform.sform_code > 0 {
        let s = &transform.srow;
        let columns = std::array::from_fn(|axis| [s[0][axis], s[1][axis], s[2][axis]]);
        ("sform", PatientOrientation::from_ras(columns, Some([s[0][3], s[1][3], s[2][3]])))
    } else if transform.qform_code > 0 {
        ("qform", PatientOrientation::from_ras(qform_columns(transform), Some(transform.qoffset_mm)))
    } else {
        return None;
    };
    if orientation.is_none() {
        log::warn!("{}: the NIfTI {which} is not finite or degenerate; orientation unknown", path.display());
    }
    orientation
}

/// The qform's rotation (nifti1_io's `nifti_quatern_to_mat44`), as the direction of each axis.
fn qform_columns(transform: &NiftiTransform) -> [[f64; 3]; 3] {
    let [mut b, mut c, mut d] = transform.quaternion_bcd;
    let mut a = 1.0 - (b * b + c * c + d * d);
    if a < 1e-7 {
        // A rotation by 180°: a is 0, and (b, c, d) is renormalised.
        let scale = 1.0 / (b * b + c * c + d * d).sqrt();
        (b, c, d, a) = (b * scale, c * scale, d * scale, 0.0);
    } else {
        a = a.sqrt();
    }
    let rows = [
        [a * a + b * b - c * c - d * d, 2.0 * (b * c - a * d), 2.0 * (b * d + a * c)],
        [2.0 * (b * c + a * d), a * a + c * c - b * b - d * d, 2.0 * (c * d - a * b)],
        [2.0 * (b * d - a * c), 2.0 * (c * d + a * b), a * a + d * d - c * c - b * b],
    ];
    let qfac = if transform.qfac < 0.0 { -1.0 } else { 1.0 };
    std::array::from_fn(|axis| {
        let sign = if axis == 2 { qfac } else { 1.0 };
        [rows[0][axis] * sign, rows[1][axis] * sign, rows[2][axis] * sign]
    })
}

/// NRRD: the `space`, `space directions` and `space origin` field values; `spatial_axes` are the
/// positions of the volume's x, y (and z) among the file's axes (a 2-D image has two; its third
/// direction is the cross product of the two). Only the anatomical spaces give an orientation.
pub fn from_nrrd(
    space: Option<&str>,
    directions: Option<&str>,
    origin: Option<&str>,
    spatial_axes: &[usize],
    path: &Path,
) -> Option<PatientOrientation> {
    let space = space?;
    let Some(signs) = nrrd_space_signs(space) else {
        if !is_known_non_anatomical_space(space) {
            log::warn!("{}: unknown NRRD space '{space}'; orientation unknown", path.display());
        }
        return None;
    };
    let to_lps = |v: [f64; 3]| [v[0] * signs[0], v[1] * signs[1], v[2] * signs[2]];
    let vectors = crate::volume::nrrd::split_direction_vectors(directions?);
    let mut columns = Vec::with_capacity(3);
    for &axis in spatial_axes {
        let Some(vector) = vectors.get(axis).and_then(|entry| parse_vector(entry)) else {
            log::warn!("{}: 'space directions' has no vector for axis {axis}; orientation unknown", path.display());
            return None;
        };
        columns.push(to_lps(vector));
    }
    if columns.len() == 2 {
        columns.push(cross(columns[0], columns[1]));
    }
    let origin = origin.and_then(parse_vector).map(to_lps);
    let orientation = PatientOrientation::new([columns[0], columns[1], columns[2]], origin);
    if orientation.is_none() {
        log::warn!("{}: NRRD 'space directions' are degenerate; orientation unknown", path.display());
    }
    orientation
}

/// The sign that takes each coordinate of a named anatomical NRRD space into LPS; `None` for
/// other spaces. Names are compared case-insensitively, as teem does.
fn nrrd_space_signs(space: &str) -> Option<[f64; 3]> {
    let name = space.trim().to_ascii_lowercase();
    let name = name.strip_suffix("-time").unwrap_or(&name);
    match name {
        "left-posterior-superior" | "lps" | "lpst" => Some([1.0, 1.0, 1.0]),
        "right-anterior-superior" | "ras" | "rast" => Some([-1.0, -1.0, 1.0]),
        "left-anterior-superior" | "las" | "last" => Some([1.0, -1.0, 1.0]),
        _ => None,
    }
}

/// teem's other named spaces: valid, but not fixed to the patient.
fn is_known_non_anatomical_space(space: &str) -> bool {
    let name = space.trim().to_ascii_lowercase();
    matches!(
        name.strip_suffix("-time").unwrap_or(&name),
        "scanner-xyz" | "3d-right-handed" | "3d-left-handed" | "3dr" | "3dl" | "3drt" | "3dlt"
    )
}

/// `(a,b,c)` (spaces allowed, a fourth component ignored) as three numbers.
fn parse_vector(entry: &str) -> Option<[f64; 3]> {
    let inner = entry.trim().strip_prefix('(')?.strip_suffix(')')?;
    let components: Vec<f64> = inner.split(',').map(|c| c.trim().parse::<f64>()).collect::<Result<_, _>>().ok()?;
    (components.len() >= 3).then(|| [components[0], components[1], components[2]])
}

/// The NRRD header lines (each ending in a newline) that say `orientation` for a grid of
/// `spacing_mm`: `space`, `space directions` (direction times spacing) and, when known,
/// `space origin`. They replace `space dimension`, which `space` implies.
pub fn nrrd_space_fields(orientation: &PatientOrientation, spacing_mm: [f64; 3]) -> String {
    // `+ 0.0` writes -0 as 0.
    let vector = |v: [f64; 3]| format!("({},{},{})", v[0] + 0.0, v[1] + 0.0, v[2] + 0.0);
    let directions: Vec<String> =
        (0..3).map(|axis| vector(orientation.axis_direction_lps(axis).map(|c| c * spacing_mm[axis]))).collect();
    let mut text = format!("space: left-posterior-superior\nspace directions: {}\n", directions.join(" "));
    if let Some(origin) = orientation.origin_lps_mm {
        text.push_str(&format!("space origin: {}\n", vector(origin)));
    }
    text
}

/// MetaImage: `TransformMatrix` (or its synonyms `Rotation`, `Orientation`), else
/// `AnatomicalOrientation`; `Offset` (or `Origin`, `Position`) as the origin. `rank` is `NDims`.
pub fn from_metaimage(
    transform_matrix: Option<&str>,
    anatomical_orientation: Option<&str>,
    offset: Option<&str>,
    rank: usize,
    path: &Path,
) -> Option<PatientOrientation> {
    let numbers = |text: &str| text.split_whitespace().map(|t| t.parse::<f64>()).collect::<Result<Vec<f64>, _>>();
    let origin = offset.and_then(|text| numbers(text).ok()).filter(|o| o.len() == rank).map(|o| {
        let mut origin = [0.0; 3];
        origin[..rank.min(3)].copy_from_slice(&o[..rank.min(3)]);
        origin
    });
    let columns = if let Some(text) = transform_matrix {
        match numbers(text) {
            Ok(values) if values.len() == rank * rank && (2..=3).contains(&rank) => {
                let mut columns = [[0.0; 3]; 3];
                for (axis, column) in columns.iter_mut().enumerate().take(rank) {
                    column[..rank].copy_from_slice(&values[axis * rank..(axis + 1) * rank]);
                }
                if rank == 2 {
                    columns[2] = cross(columns[0], columns[1]);
                }
                columns
            }
            _ => {
                log::warn!(
                    "{}: TransformMatrix '{text}' is not {rank}x{rank} numbers; orientation unknown",
                    path.display()
                );
                return None;
            }
        }
    } else {
        let letters = anatomical_orientation?.trim();
        match from_letters(letters) {
            Some(columns) if letters.len() == 3 => columns,
            _ => {
                if letters != "???" {
                    log::warn!(
                        "{}: AnatomicalOrientation '{letters}' is not three letters from RLAPIS, one per axis; orientation unknown",
                        path.display()
                    );
                }
                return None;
            }
        }
    };
    let orientation = PatientOrientation::new(columns, origin);
    if orientation.is_none() {
        log::warn!("{}: the MetaImage direction matrix is degenerate; orientation unknown", path.display());
    }
    orientation
}

/// ITK's "from" letters (`RAI`: x from right to left, ...) as the LPS direction of each axis.
fn from_letters(letters: &str) -> Option<[[f64; 3]; 3]> {
    let mut columns = [[0.0; 3]; 3];
    for (column, letter) in columns.iter_mut().zip(letters.chars()) {
        let (axis, sign) = match letter.to_ascii_uppercase() {
            'R' => (0, 1.0),
            'L' => (0, -1.0),
            'A' => (1, 1.0),
            'P' => (1, -1.0),
            'I' => (2, 1.0),
            'S' => (2, -1.0),
            _ => return None,
        };
        column[axis] = sign;
    }
    Some(columns)
}
