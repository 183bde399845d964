//! The 3-D view's home position for an oriented volume: an anterior view (the camera in front
//! of the patient's face) with superior up, in the orbit camera's own terms
//! (`render::camera`: azimuth and elevation around the box centre; the world frame is the
//! voxel axes in millimetres, +z up at elevation 0; the camera never rolls, so its "up" always
//! lies in the vertical plane through the view direction).
//!
//! The camera's frame (right, up, towards the eye) should be the patient's (left, superior,
//! anterior), expressed in the voxel frame through the orientation. Without roll that is
//! possible exactly when the patient's left-right axis is horizontal in the volume's box (true
//! of axial stacks, tilted ones included); otherwise the best camera without roll is chosen,
//! giving "superior up" twice the weight of "seen from the front", and `exact` says so.
//! A left-handed volume (a mirror frame, e.g. NIfTI stored `LAS`) cannot be shown unmirrored
//! by any camera: `mirrored` says the renderer would have to flip an axis.
//!
//! Entry point: [`HomeView::of`]. With an unknown orientation there is no home view: keep the
//! renderer's default camera.
//!
//! Never: touches the renderer (the caller copies the two angles into its camera).

use crate::volume::{PatientDirection, PatientOrientation};

/// Weights of "towards the eye is anterior" and "up is superior" when both cannot hold.
const ANTERIOR_WEIGHT: f64 = 1.0;
const SUPERIOR_WEIGHT: f64 = 2.0;

/// An orbit camera's home angles (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomeView {
    /// The orbit camera's azimuth in degrees, counter-clockwise about +z seen from above.
    pub azimuth_degrees: f32,
    /// The orbit camera's elevation in degrees above the xy plane.
    pub elevation_degrees: f32,
    /// The camera's up direction in the world (voxel) frame at these angles, unit length.
    pub up_in_world: [f32; 3],
    /// True when the view is exactly anterior with superior exactly up.
    pub exact: bool,
    /// True when the volume's axes are a mirror frame of the patient: the view shows the
    /// patient's left on the screen's left unless the renderer flips an axis.
    pub mirrored: bool,
}

impl HomeView {
    /// The home view of a volume with `orientation`.
    pub fn of(orientation: &PatientOrientation) -> HomeView {
        let toward =
            |direction: PatientDirection| normalise(orientation.voxel_frame_from_patient(direction.lps_vector()));
        let (anterior, superior) = (toward(PatientDirection::Anterior), toward(PatientDirection::Superior));
        // For an azimuth, the best elevation and its score (module doc): with h the horizontal
        // direction towards the eye at elevation 0, towards_eye = cos(e) h + sin(e) z and
        // up = cos(e) z - sin(e) h.
        let best_at = |azimuth: f64| {
            let h = [azimuth.sin(), -azimuth.cos(), 0.0];
            let along = ANTERIOR_WEIGHT * dot(anterior, h) + SUPERIOR_WEIGHT * superior[2];
            let across = ANTERIOR_WEIGHT * anterior[2] - SUPERIOR_WEIGHT * dot(superior, h);
            (across.atan2(along), along.hypot(across))
        };
        // The camera's right must be the patient's left, i.e. superior x anterior in the volume's
        // frame (right = up x towards-eye): its horizontal direction is the exact azimuth when
        // there is one. A sweep in half degrees covers the rest.
        let right = cross(superior, anterior);
        let mut candidates: Vec<f64> = (0..720).map(|step| (step as f64 * 0.5).to_radians()).collect();
        if right[0].hypot(right[1]) > 1e-9 {
            candidates.insert(0, right[1].atan2(right[0]));
        }
        let mut best = (0.0, 0.0, f64::NEG_INFINITY);
        for azimuth in candidates {
            let (elevation, score) = best_at(azimuth);
            if score > best.2 + 1e-12 {
                best = (azimuth, elevation, score);
            }
        }
        let (azimuth, elevation, score) = best;
        let h = [azimuth.sin(), -azimuth.cos(), 0.0];
        let up = [-elevation.sin() * h[0], -elevation.sin() * h[1], elevation.cos()];
        HomeView {
            azimuth_degrees: wrap_degrees(azimuth.to_degrees()) as f32,
            elevation_degrees: wrap_degrees(elevation.to_degrees()) as f32,
            up_in_world: up.map(|c| c as f32),
            exact: score >= ANTERIOR_WEIGHT + SUPERIOR_WEIGHT - 1e-6,
            mirrored: !orientation.is_right_handed(),
        }
    }
}

/// An angle in (-180, 180] degrees.
fn wrap_degrees(degrees: f64) -> f64 {
    let wrapped = (degrees + 180.0).rem_euclid(360.0) - 180.0;
    if wrapped <= -180.0 { wrapped + 360.0 } else { wrapped }
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let length = dot(v, v).sqrt();
    if length > 0.0 { v.map(|c| c / length) } else { v }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::{Camera, Projection};

    fn view_of(directions: [[f64; 3]; 3]) -> (HomeView, PatientOrientation) {
        let orientation = PatientOrientation::new(directions, None).unwrap();
        (HomeView::of(&orientation), orientation)
    }

    /// The renderer's camera at the home angles: where it looks from and what is up, in LPS.
    fn seen(view: &HomeView, orientation: &PatientOrientation) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let camera = Camera {
            azimuth_degrees: view.azimuth_degrees,
            elevation_degrees: view.elevation_degrees,
            projection: Projection::Orthographic,
            ..Camera::default()
        };
        let rays = camera.view_rays([100.0, 100.0, 100.0], 64, 64);
        let to_lps = |v: [f32; 3]| -> [f64; 3] {
            let d = orientation.axis_directions_lps();
            std::array::from_fn(|c| (0..3).map(|a| v[a] as f64 * d[a][c]).sum())
        };
        let towards_eye = rays.forward_in_world.map(|c| -c);
        for (a, b) in rays.up_in_world.iter().zip(&view.up_in_world) {
            assert!((a - b).abs() < 1e-5, "up_in_world matches the renderer's");
        }
        (to_lps(towards_eye), to_lps(rays.up_in_world), to_lps(rays.right_in_world))
    }

    fn close(a: [f64; 3], b: [f64; 3], tolerance: f64) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < tolerance)
    }

    #[test]
    fn axial_stacks_are_seen_from_the_front_with_the_head_up() {
        let tilt = 18.5f64.to_radians();
        let cases = [
            ("LPS", [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
            ("RAI (feet first, flipped in-plane)", [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]),
            ("LPI", [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]),
            ("tilted GE head", [[1.0, 0.0, 0.0], [0.0, tilt.cos(), -tilt.sin()], [0.0, tilt.sin(), tilt.cos()]]),
        ];
        for (name, directions) in cases {
            let (view, orientation) = view_of(directions);
            assert!(view.exact && !view.mirrored, "{name}: {view:?}");
            let (towards_eye, up, right) = seen(&view, &orientation);
            assert!(close(towards_eye, [0.0, -1.0, 0.0], 1e-4), "{name}: eye towards {towards_eye:?}");
            assert!(close(up, [0.0, 0.0, 1.0], 1e-4), "{name}: up {up:?}");
            assert!(close(right, [1.0, 0.0, 0.0], 1e-4), "{name}: the patient's left on the right {right:?}");
        }
        // The GE head: the camera sits 18.5° below the volume's horizontal to undo the tilt.
        let (ge, _) = view_of(cases[3].1);
        assert!((ge.elevation_degrees + 18.5).abs() < 1e-3 && ge.azimuth_degrees.abs() < 1e-3, "{ge:?}");
    }

    #[test]
    fn a_sagittal_stack_keeps_the_head_up_and_a_mirror_frame_is_reported() {
        // Voxel x toward anterior, y toward inferior, z toward the left: left-right is vertical
        // in the box, so no camera without roll sees the face with the head up; superior wins.
        let (view, orientation) = view_of([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]);
        assert!(!view.exact);
        let (_, up, _) = seen(&view, &orientation);
        assert!(close(up, [0.0, 0.0, 1.0], 1e-3), "up {up:?}");
        // NIfTI's common LAS storage is a mirror frame: still anterior and superior, mirrored.
        let (view, orientation) = view_of([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!(view.mirrored && view.exact, "{view:?}");
        let (towards_eye, up, _) = seen(&view, &orientation);
        assert!(close(towards_eye, [0.0, -1.0, 0.0], 1e-4) && close(up, [0.0, 0.0, 1.0], 1e-4));
    }
}
