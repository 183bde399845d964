use super::*;

fn oriented(directions: [[f64; 3]; 3]) -> PatientOrientation {
    PatientOrientation::new(directions, None).unwrap()
}

const LPS: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The patient direction screen-right and screen-down point to, read back from a layout.
fn screen_directions(layout: &SliceLayout, orientation: &PatientOrientation) -> (PatientDirection, PatientDirection) {
    let direction = |axis: usize, reversed: bool| {
        let d = orientation.anatomical_axes()[axis];
        if reversed { d.opposite() } else { d }
    };
    (direction(layout.across_axis, layout.across_reversed), direction(layout.down_axis, layout.down_reversed))
}

#[test]
fn lps_volumes_show_in_the_radiological_convention() {
    let orientation = oriented(LPS);
    assert_eq!(plane_axes(Some(&orientation)), [Axis::Z, Axis::Y, Axis::X]);
    let axial = SliceLayout::new(Some(&orientation), Axis::Z);
    assert_eq!(axial.plane, Some(PlaneKind::Axial));
    // x increases toward the left: already left-to-right on screen; y toward posterior: down.
    assert_eq!((axial.across_axis, axial.across_reversed, axial.down_axis, axial.down_reversed), (0, false, 1, false));
    assert_eq!(axial.edge_letters, Some(EdgeLetters { left: "R", right: "L", top: "A", bottom: "P" }));
    let coronal = SliceLayout::new(Some(&orientation), Axis::Y);
    // z increases toward superior, so it is reversed to put superior up.
    assert_eq!(
        (coronal.across_axis, coronal.across_reversed, coronal.down_axis, coronal.down_reversed),
        (0, false, 2, true)
    );
    assert_eq!(coronal.edge_letters, Some(EdgeLetters { left: "R", right: "L", top: "S", bottom: "I" }));
    let sagittal = SliceLayout::new(Some(&orientation), Axis::X);
    // y toward posterior runs left to right (anterior on the left), z reversed (superior up).
    assert_eq!(
        (sagittal.across_axis, sagittal.across_reversed, sagittal.down_axis, sagittal.down_reversed),
        (1, false, 2, true)
    );
    assert_eq!(sagittal.edge_letters, Some(EdgeLetters { left: "A", right: "P", top: "S", bottom: "I" }));
}

#[test]
fn flipped_and_permuted_volumes_get_the_same_picture_of_the_patient() {
    let cases = [
        ("LPS", LPS),
        ("RAS (NIfTI-like, x and y flipped)", [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]),
        ("LAS (mirror)", [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]),
        ("sagittal MRI: x anterior, y inferior, z left", [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]),
        ("coronal stack: x left, y inferior, z posterior", [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    ];
    for (name, directions) in cases {
        let orientation = oriented(directions);
        let axes = plane_axes(Some(&orientation));
        for (plane, axis) in PlaneKind::ALL.into_iter().zip(axes) {
            let layout = SliceLayout::new(Some(&orientation), axis);
            assert_eq!(layout.plane, Some(plane), "{name}");
            assert_eq!(screen_directions(&layout, &orientation), plane.screen_right_and_down(), "{name} {plane:?}");
            assert_ne!(layout.across_axis, layout.down_axis);
            assert!(layout.across_axis != axis.position() && layout.down_axis != axis.position());
        }
    }
    // The sagittal MRI: axial panel normal to voxel y, coronal to x, sagittal to z.
    assert_eq!(plane_axes(Some(&oriented(cases[3].1))), [Axis::Y, Axis::X, Axis::Z]);
}

#[test]
fn without_orientation_the_stored_order_shows_and_no_letters() {
    assert_eq!(plane_axes(None), [Axis::Z, Axis::Y, Axis::X]);
    for axis in Axis::ALL {
        let layout = SliceLayout::new(None, axis);
        assert_eq!(layout.plane, None);
        assert_eq!(layout.edge_letters, None);
        assert_eq!([layout.across_axis, layout.down_axis], axis.image_axes());
        assert!(!layout.across_reversed && !layout.down_reversed && !layout.transposed());
        let dims = [5, 6, 7];
        assert_eq!(layout.screen_from_image([1.5, 2.0], dims), [1.5, 2.0]);
    }
}

#[test]
fn screen_and_image_points_round_trip_and_pixels_follow_them() {
    // A sagittal MRI (transposes and flips) and an LPS volume (flips only), 4 x 5 x 6 voxels.
    let dims = [4, 5, 6];
    for directions in [
        LPS,
        [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]],
        [[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]],
    ] {
        let orientation = oriented(directions);
        for axis in Axis::ALL {
            let layout = SliceLayout::new(Some(&orientation), axis);
            let [column_axis, row_axis] = axis.image_axes();
            let (width, height) = (dims[column_axis], dims[row_axis]);
            // Each pixel holds its own (i, j) so the arranged picture can be read back.
            let pixels: Vec<u8> = (0..height).flat_map(|j| (0..width).flat_map(move |i| [i as u8, j as u8])).collect();
            let (arranged, screen_width, screen_height) = layout.arrange_pixels(&pixels, 2, width, height).unwrap();
            assert_eq!([screen_width, screen_height], layout.screen_size(dims));
            for v in 0..screen_height {
                for u in 0..screen_width {
                    let image = layout.image_from_screen([u as f64, v as f64], dims);
                    let pixel = &arranged[2 * (v * screen_width + u)..][..2];
                    assert_eq!([pixel[0] as f64, pixel[1] as f64], image, "{directions:?} {axis} ({u}, {v})");
                    assert_eq!(layout.screen_from_image(image, dims), [u as f64, v as f64]);
                }
            }
            // Continuous points (lasso vertices, half a voxel outside the slice) round-trip too.
            for point in [[-0.5, 0.25], [2.75, 3.5]] {
                let back = layout.image_from_screen(layout.screen_from_image(point, dims), dims);
                assert!((back[0] - point[0]).abs() < 1e-12 && (back[1] - point[1]).abs() < 1e-12);
            }
            let voxel = layout.voxel_from_screen([0.0, 0.0], dims, 2);
            let image = layout.image_from_screen([0.0, 0.0], dims);
            assert_eq!((voxel[column_axis], voxel[row_axis], voxel[axis.position()]), (image[0], image[1], 2.0));
            assert!(layout.arrange_pixels(&pixels[1..], 2, width, height).is_none());
        }
    }
}

#[test]
fn a_tilted_volume_takes_the_nearest_planes() {
    let tilt = 18.5f64.to_radians();
    let orientation = oriented([[1.0, 0.0, 0.0], [0.0, tilt.cos(), -tilt.sin()], [0.0, tilt.sin(), tilt.cos()]]);
    assert_eq!(plane_axes(Some(&orientation)), [Axis::Z, Axis::Y, Axis::X]);
    let coronal = SliceLayout::new(Some(&orientation), Axis::Y);
    assert_eq!(coronal.edge_letters.map(|l| l.top), Some("S"));
    assert!(coronal.down_reversed, "z runs toward superior, so it is flipped to put the head up");
    assert_eq!(SliceLayout::new(Some(&orientation), Axis::Z).screen_extent_mm([4, 5, 6], [0.5, 0.5, 4.0]), [2.0, 2.5]);
}
