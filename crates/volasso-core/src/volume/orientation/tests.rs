use super::*;
use std::path::Path;

fn letters(directions: [[f64; 3]; 3]) -> [&'static str; 3] {
    PatientOrientation::new(directions, None).unwrap().anatomical_letters()
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6)
}

#[test]
fn axis_aligned_flipped_and_permuted_axes_get_dicom_letters() {
    assert_eq!(letters([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), ["L", "P", "S"]);
    assert_eq!(letters([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]), ["R", "A", "I"]);
    // A sagittal stack: x toward anterior, y toward inferior (rows go down), z toward the left.
    assert_eq!(letters([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]), ["A", "I", "L"]);
    // Lengths do not matter.
    assert_eq!(letters([[0.0, 0.0, 2.5], [-0.4, 0.0, 0.0], [0.0, 7.0, 0.0]]), ["S", "R", "P"]);
}

#[test]
fn oblique_axes_get_the_nearest_letters_and_never_share_one() {
    let tilt = 18.5f64.to_radians();
    // The tilted GE head: y leans from posterior toward inferior, z from superior toward posterior.
    let ge = [[1.0, 0.0, 0.0], [0.0, tilt.cos(), -tilt.sin()], [0.0, tilt.sin(), tilt.cos()]];
    assert_eq!(letters(ge), ["L", "P", "S"]);
    // 45° in the axial plane: per-axis nearest would be a tie; the assignment keeps them apart.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let diagonal = PatientOrientation::new([[h, h, 0.0], [-h, h, 0.0], [0.0, 0.0, 1.0]], None).unwrap();
    let mut patient_axes = diagonal.anatomical_axes().map(|d| d.lps_axis().0);
    patient_axes.sort();
    assert_eq!(patient_axes, [0, 1, 2], "{:?}", diagonal.anatomical_letters());
    assert_eq!(diagonal.anatomical_letters()[2], "S");
    // 60° off x: x is nearer posterior than left.
    let (c, s) = (60f64.to_radians().cos(), 60f64.to_radians().sin());
    assert_eq!(letters([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]), ["P", "R", "S"]);
}

#[test]
fn degenerate_and_non_finite_directions_are_no_orientation() {
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!(PatientOrientation::new(identity, None).is_some());
    let mut zero = identity;
    zero[1] = [0.0; 3];
    assert!(PatientOrientation::new(zero, None).is_none());
    let mut parallel = identity;
    parallel[2] = [1.0, 0.001, 0.0];
    assert!(PatientOrientation::new(parallel, None).is_none());
    let mut nan = identity;
    nan[0][1] = f64::NAN;
    assert!(PatientOrientation::new(nan, None).is_none());
    let infinite_origin = PatientOrientation::new(identity, Some([0.0, f64::INFINITY, 0.0])).unwrap();
    assert_eq!(infinite_origin.origin_lps_mm, None);
}

#[test]
fn patient_directions_map_back_to_voxel_axes() {
    let tilt = 18.5f64.to_radians();
    let directions = [[-1.0, 0.0, 0.0], [0.0, tilt.cos(), -tilt.sin()], [0.0, tilt.sin(), tilt.cos()]];
    let orientation = PatientOrientation::new(directions, None).unwrap();
    for direction in [PatientDirection::Superior, PatientDirection::Anterior, PatientDirection::Left] {
        let v = orientation.voxel_frame_from_patient(direction.lps_vector());
        let back: [f64; 3] = std::array::from_fn(|c| (0..3).map(|a| v[a] * directions[a][c]).sum());
        assert!(close(back, direction.lps_vector()), "{direction:?}: {back:?}");
    }
    assert_eq!(orientation.voxel_axis_toward(PatientDirection::Right), (0, true));
    assert_eq!(orientation.voxel_axis_toward(PatientDirection::Anterior), (1, false));
    assert_eq!(orientation.voxel_axis_toward(PatientDirection::Superior), (2, true));
    assert!(!orientation.is_right_handed(), "x flipped to the right makes a mirror frame");
}

#[test]
fn dicom_axes_are_rows_columns_and_their_normal() {
    let axial = from_dicom([1.0, 0.0, 0.0, 0.0, 1.0, 0.0], Some([-125.0, -120.0, 5.8]), Path::new("t")).unwrap();
    assert_eq!(axial.anatomical_letters(), ["L", "P", "S"]);
    assert_eq!(axial.origin_lps_mm, Some([-125.0, -120.0, 5.8]));
    // Coronal images: rows toward the left, columns toward the feet; the normal r x c points
    // posterior.
    let coronal = from_dicom([1.0, 0.0, 0.0, 0.0, 0.0, -1.0], None, Path::new("t")).unwrap();
    assert_eq!(coronal.anatomical_letters(), ["L", "I", "P"]);
    assert!(from_dicom([0.0; 6], None, Path::new("t")).is_none());
}

#[test]
fn nifti_prefers_the_sform_reads_the_qform_and_flips_ras_into_lps() {
    // anatomical.nii's header: qform (b, c, d) = (0, 1, 0), qfac -1, qoffset (32, -40, -16);
    // nibabel gives the affine diag(-2, 2, 2) and axis codes ('L', 'A', 'S').
    let qform = NiftiTransform {
        qform_code: 2,
        quaternion_bcd: [0.0, 1.0, 0.0],
        qoffset_mm: [32.0, -40.0, -16.0],
        qfac: -1.0,
        ..NiftiTransform::default()
    };
    let orientation = from_nifti(&qform, Path::new("t.nii")).unwrap();
    assert_eq!(orientation.anatomical_letters(), ["L", "A", "S"]);
    assert!(close(orientation.axis_direction_lps(0), [1.0, 0.0, 0.0]));
    assert!(close(orientation.axis_direction_lps(1), [0.0, -1.0, 0.0]));
    assert_eq!(orientation.origin_lps_mm, Some([-32.0, 40.0, -16.0]));
    // qfac +1 leaves the third axis as the rotation has it: toward the feet.
    let no_flip = NiftiTransform { qfac: 1.0, ..qform };
    assert_eq!(from_nifti(&no_flip, Path::new("t.nii")).unwrap().anatomical_letters(), ["L", "A", "I"]);
    // An sform (x toward anterior, y toward the left, z up, 2 mm) wins over the qform.
    let both = NiftiTransform {
        sform_code: 1,
        srow: [[0.0, -2.0, 0.0, 10.0], [2.0, 0.0, 0.0, 20.0], [0.0, 0.0, 2.0, 30.0]],
        ..qform
    };
    let orientation = from_nifti(&both, Path::new("t.nii")).unwrap();
    assert_eq!(orientation.anatomical_letters(), ["A", "L", "S"]);
    assert_eq!(orientation.origin_lps_mm, Some([-10.0, -20.0, 30.0]));
    // Neither code set: the file does not say. A degenerate sform says nothing usable.
    assert!(from_nifti(&NiftiTransform { qform_code: 0, ..qform }, Path::new("t.nii")).is_none());
    let flat = NiftiTransform { sform_code: 1, srow: [[0.0; 4]; 3], ..NiftiTransform::default() };
    assert!(from_nifti(&flat, Path::new("t.nii")).is_none());
}

#[test]
fn a_half_turn_quaternion_is_renormalised_as_nifti1_io_does() {
    // (b, c, d) = (0, 0, 1): 180° about z, so x toward the left in RAS's -x, y toward posterior.
    let turn = NiftiTransform { qform_code: 1, quaternion_bcd: [0.0, 0.0, 1.0], ..NiftiTransform::default() };
    assert_eq!(from_nifti(&turn, Path::new("t")).unwrap().anatomical_letters(), ["L", "P", "S"]);
}

#[test]
fn nrrd_spaces_flip_into_lps_and_others_say_nothing() {
    let directions = "(0,0.5,0) (-0.5,0,0) (0,0,2)";
    let axes = [0, 1, 2];
    for (space, expected) in [
        ("left-posterior-superior", ["P", "R", "S"]),
        ("LPS", ["P", "R", "S"]),
        ("right-anterior-superior", ["A", "L", "S"]),
        ("RAS", ["A", "L", "S"]),
        ("left-anterior-superior", ["A", "R", "S"]),
    ] {
        let orientation = from_nrrd(Some(space), Some(directions), None, &axes, Path::new("t")).unwrap();
        assert_eq!(orientation.anatomical_letters(), expected, "{space}");
    }
    for space in ["scanner-xyz", "3D-right-handed", "banana"] {
        assert!(from_nrrd(Some(space), Some(directions), None, &axes, Path::new("t")).is_none(), "{space}");
    }
    assert!(from_nrrd(None, Some(directions), None, &axes, Path::new("t")).is_none());
    let with_origin = from_nrrd(Some("RAS"), Some(directions), Some("(1, 2, 3)"), &axes, Path::new("t")).unwrap();
    assert_eq!(with_origin.origin_lps_mm, Some([-1.0, -2.0, 3.0]));
    // A leading non-spatial axis, and a 2-D image whose third direction is the normal.
    let vector = from_nrrd(Some("LPS"), Some(&format!("none {directions}")), None, &[1, 2, 3], Path::new("t"));
    assert_eq!(vector.unwrap().anatomical_letters(), ["P", "R", "S"]);
    let image = from_nrrd(Some("LPS"), Some("(1,0,0) (0,0,-1)"), None, &[0, 1], Path::new("t")).unwrap();
    assert_eq!(image.anatomical_letters(), ["L", "I", "P"]);
}

#[test]
fn metaimage_transform_matrix_lists_each_axis_direction_in_turn() {
    // Axis x toward anterior (0,-1,0), y toward the left, z toward superior.
    let matrix = "0 -1 0 1 0 0 0 0 1";
    let orientation = from_metaimage(Some(matrix), Some("RAI"), Some("5 6 7"), 3, Path::new("t")).unwrap();
    assert_eq!(orientation.anatomical_letters(), ["A", "L", "S"]);
    assert_eq!(orientation.origin_lps_mm, Some([5.0, 6.0, 7.0]));
    // Without a matrix, ITK's "from" letters: RAI is LPS, LPS is its mirror RAI.
    assert_eq!(
        from_metaimage(None, Some("RAI"), None, 3, Path::new("t")).unwrap().anatomical_letters(),
        ["L", "P", "S"]
    );
    assert_eq!(
        from_metaimage(None, Some("LPS"), None, 3, Path::new("t")).unwrap().anatomical_letters(),
        ["R", "A", "I"]
    );
    assert_eq!(
        from_metaimage(None, Some("PIR"), None, 3, Path::new("t")).unwrap().anatomical_letters(),
        ["A", "S", "L"]
    );
    for (matrix, letters) in
        [(Some("1 0 0 0 1"), None), (Some("1 0 0 0 1 0 0 0 x"), None), (None, Some("RAX")), (None, Some("RRI"))]
    {
        assert!(from_metaimage(matrix, letters, None, 3, Path::new("t")).is_none(), "{matrix:?} {letters:?}");
    }
    assert!(from_metaimage(None, None, Some("1 2 3"), 3, Path::new("t")).is_none());
    let flat = from_metaimage(Some("1 0 0 -1"), None, None, 2, Path::new("t")).unwrap();
    assert_eq!(flat.anatomical_letters(), ["L", "A", "I"]);
}

#[test]
fn nrrd_space_fields_read_back_as_the_same_orientation() {
    let tilt = 18.5f64.to_radians();
    let directions = [[-1.0, 0.0, 0.0], [0.0, tilt.cos(), -tilt.sin()], [0.0, tilt.sin(), tilt.cos()]];
    let orientation = PatientOrientation::new(directions, Some([-125.0, -119.0, -33.7])).unwrap();
    let spacing = [0.48828125, 0.48828125, 4.0025];
    let text = format!(
        "NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\n{}endian: little\nencoding: raw\n\n",
        nrrd_space_fields(&orientation, spacing)
    );
    let header = crate::volume::nrrd::parse_header(text.as_bytes(), Path::new("t.nrrd")).unwrap();
    let read = header.orientation.unwrap();
    for axis in 0..3 {
        assert!(close(read.axis_direction_lps(axis), directions[axis]), "axis {axis}");
        assert!((header.spacing_mm[axis] - spacing[axis]).abs() < 1e-12, "axis {axis}");
    }
    assert_eq!(read.origin_lps_mm, orientation.origin_lps_mm);
}
