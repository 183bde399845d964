//! The clip plane by touch: where "Clip" puts the plane (through the volume's centre, facing
//! the viewer, so the half nearer the eye is cut away), how one finger moves it along its
//! normal and two fingers tilt it, and how the slices show what it cuts (the cut-away part of
//! each slice picture is dimmed, so the slices and the 3-D view agree). The plane is a
//! [`ClipPlane`] in the ray caster's world space (millimetres, the volume's box centred on the
//! origin), which is also how the session saves it.
//!
//! Never: touches the UI or the renderer; it only computes planes and dims pictures.

use volasso_core::render::{Camera, ClipPlane};
use volasso_core::slices::SliceLayout;
use volasso_core::transfer::RgbImage;

/// Degrees the plane tilts per pixel of two-finger pan.
const TILT_DEGREES_PER_PIXEL: f32 = 0.4;
/// How much of a cut-away slice pixel's brightness is kept.
const CUT_BRIGHTNESS: f32 = 0.3;

/// The volume's box in mm, `dims * spacing`.
pub fn extent_mm(dims: [usize; 3], spacing_mm: [f64; 3]) -> [f32; 3] {
    std::array::from_fn(|a| (dims[a] as f64 * spacing_mm[a]) as f32)
}

/// The plane "Clip" starts with: through the centre, its normal toward the eye.
pub fn initial(camera: &Camera, extent_mm: [f32; 3]) -> ClipPlane {
    let forward = camera.view_rays(extent_mm, 1, 1).forward_in_world;
    ClipPlane { normal: forward.map(|f| -f), offset_mm: 0.0 }
}

/// The plane moved along its normal by a finger's drag of `down_pixels` on a view
/// `view_height` pixels high: dragging up pushes it away from the viewer (cutting more), the
/// whole view's height moving it across the volume's diagonal. It never leaves the volume's
/// bounding sphere.
pub fn moved(plane: ClipPlane, down_pixels: f32, view_height: u32, extent_mm: [f32; 3]) -> ClipPlane {
    let diagonal = extent_mm.iter().map(|e| e * e).sum::<f32>().sqrt();
    let Some(unit) = plane.normalised() else { return plane };
    if !down_pixels.is_finite() {
        return unit;
    }
    let offset = unit.offset_mm + down_pixels * diagonal / view_height.max(1) as f32;
    ClipPlane { offset_mm: offset.clamp(-0.5 * diagonal, 0.5 * diagonal), ..unit }
}

/// The plane tilted by a two-finger gesture: a pan of `pan_pixels` turns its normal about the
/// view's up (sideways) and right (up and down) axes, `turn_degrees` about the view direction.
/// The plane keeps its distance from the centre.
pub fn tilted(
    plane: ClipPlane,
    camera: &Camera,
    extent_mm: [f32; 3],
    pan_pixels: [f32; 2],
    turn_degrees: f32,
) -> ClipPlane {
    let Some(unit) = plane.normalised() else { return plane };
    let rays = camera.view_rays(extent_mm, 1, 1);
    let mut normal = unit.normal;
    let turns = [
        (rays.up_in_world, pan_pixels[0] * TILT_DEGREES_PER_PIXEL),
        (rays.right_in_world, pan_pixels[1] * TILT_DEGREES_PER_PIXEL),
        (rays.forward_in_world, turn_degrees),
    ];
    for (axis, degrees) in turns {
        if degrees.is_finite() {
            normal = rotate(normal, axis, degrees.to_radians());
        }
    }
    ClipPlane { normal, ..unit }.normalised().unwrap_or(unit)
}

/// `v` turned by `angle` radians about the unit vector `axis` (Rodrigues).
fn rotate(v: [f32; 3], axis: [f32; 3], angle: f32) -> [f32; 3] {
    let (sin, cos) = angle.sin_cos();
    let dot: f32 = (0..3).map(|a| v[a] * axis[a]).sum();
    let cross = [axis[1] * v[2] - axis[2] * v[1], axis[2] * v[0] - axis[0] * v[2], axis[0] * v[1] - axis[1] * v[0]];
    std::array::from_fn(|a| v[a] * cos + cross[a] * sin + axis[a] * dot * (1.0 - cos))
}

/// The world point (mm) of continuous voxel coordinates `voxel` (voxel i spans i to i + 1).
fn world_of(voxel: [f64; 3], extent_mm: [f32; 3], dims: [usize; 3]) -> [f32; 3] {
    std::array::from_fn(|a| ((voxel[a] / dims[a].max(1) as f64 - 0.5) as f32) * extent_mm[a])
}

/// Dims the pixels of a slice picture (as [`SliceLayout`] arranges it for the screen, one pixel
/// a voxel) whose voxel `plane` cuts away.
pub fn dim_cut(
    picture: &mut RgbImage,
    layout: &SliceLayout,
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    slice: usize,
    plane: &ClipPlane,
) {
    let Some(unit) = plane.normalised() else { return };
    let extent = extent_mm(dims, spacing_mm);
    let width = picture.width;
    for (index, pixel) in picture.pixels.chunks_exact_mut(3).enumerate() {
        let screen = [(index % width.max(1)) as f64 + 0.5, (index / width.max(1)) as f64 + 0.5];
        let mut voxel = layout.voxel_from_screen(screen, dims, slice);
        voxel[layout.axis.position()] += 0.5;
        if unit.cuts(world_of(voxel, extent, dims)) {
            for channel in pixel {
                *channel = (*channel as f32 * CUT_BRIGHTNESS).round() as u8;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volasso_core::slices::Axis;

    const EXTENT: [f32; 3] = [100.0, 80.0, 60.0];

    #[test]
    fn the_first_plane_faces_the_viewer_through_the_centre_and_a_drag_moves_it() {
        let camera = Camera::default();
        let plane = initial(&camera, EXTENT);
        let forward = camera.view_rays(EXTENT, 1, 1).forward_in_world;
        let along: f32 = (0..3).map(|a| plane.normal[a] * forward[a]).sum();
        assert!((along + 1.0).abs() < 1e-5, "normal toward the eye: {plane:?}");
        // The eye's side is cut, the far side kept.
        let near = forward.map(|f| -20.0 * f);
        assert!(plane.cuts(near) && !plane.cuts(near.map(|c| -c)));
        // Up by a whole view: across the diagonal, clamped to the bounding sphere.
        let up = moved(plane, -400.0, 400, EXTENT);
        let diagonal = EXTENT.iter().map(|e| e * e).sum::<f32>().sqrt();
        assert!((up.offset_mm + 0.5 * diagonal).abs() < 1e-3, "{up:?}");
        assert!(up.cuts([0.0; 3]), "pushed away, the centre is cut");
        assert_eq!(moved(plane, f32::NAN, 400, EXTENT).offset_mm, 0.0);
    }

    #[test]
    fn two_fingers_tilt_the_normal_and_keep_its_distance() {
        let camera = Camera::default();
        let plane = ClipPlane { offset_mm: 5.0, ..initial(&camera, EXTENT) };
        let tilted = tilted(plane, &camera, EXTENT, [225.0, 0.0], 0.0);
        let turned: f32 = (0..3).map(|a| plane.normal[a] * tilted.normal[a]).sum();
        assert!((turned - 90f32.to_radians().cos()).abs() < 1e-4, "225 px turn 90 degrees: {turned}");
        assert_eq!(tilted.offset_mm, 5.0);
        let length: f32 = tilted.normal.iter().map(|n| n * n).sum::<f32>().sqrt();
        assert!((length - 1.0).abs() < 1e-5);
        // A twist about the view direction leaves a normal along it alone.
        let twisted = super::tilted(plane, &camera, EXTENT, [0.0; 2], 45.0);
        assert!((0..3).all(|a| (twisted.normal[a] - plane.normal[a]).abs() < 1e-5));
    }

    #[test]
    fn the_cut_part_of_a_slice_is_dimmed_and_the_rest_kept() {
        let dims = [10, 8, 6];
        let layout = SliceLayout::new(None, Axis::Z);
        let [width, height] = layout.screen_size(dims);
        let mut picture = RgbImage { width, height, pixels: vec![200; width * height * 3] };
        // Cut away x > 0: the right half of the volume, in voxels 5..10.
        let plane = ClipPlane { normal: [1.0, 0.0, 0.0], offset_mm: 0.0 };
        dim_cut(&mut picture, &layout, dims, [1.0; 3], 3, &plane);
        let dimmed: usize = picture.pixels.chunks_exact(3).filter(|p| p[0] == 60).count();
        assert_eq!(dimmed, width * height / 2);
        for y in 0..height {
            for x in 0..width {
                let voxel = layout.voxel_from_screen([x as f64 + 0.5, y as f64 + 0.5], dims, 3);
                let expected = if voxel[0] > 5.0 { 60 } else { 200 };
                assert_eq!(picture.pixels[3 * (y * width + x)], expected, "screen ({x}, {y}), voxel {voxel:?}");
            }
        }
    }
}
