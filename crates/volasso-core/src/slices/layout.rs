//! How a slice lies on the screen: which voxel axis runs left to right and which top to
//! bottom, flipped or not, so that slices show in the radiological convention, and the patient
//! letters at the panel's edges. Pure arithmetic; the UI draws with it.
//!
//! The convention (what a radiologist expects):
//! * axial, seen from the feet: anterior up, the patient's right on the screen's left;
//! * coronal, seen from the front: superior up, the patient's right on the screen's left;
//! * sagittal: superior up, anterior on the screen's left.
//!
//! Which panel is which: a slice is *axial* when the voxel axis normal to it is the one whose
//! nearest patient direction is superior-inferior (and likewise coronal for posterior-anterior,
//! sagittal for left-right), with the nearest directions assigned one per axis
//! ([`PatientOrientation::anatomical_axes`]). So a sagittally acquired MRI has its axial panel
//! normal to voxel y, and an oblique (tilted) volume gets the plane nearest each kind; its
//! edge letters are the nearest single letters too.
//!
//! Coordinates: an *image point* is in the slice image of [`super::slice_image`] (for axis z
//! `[x, y]`, for y `[x, z]`, for x `[y, z]`; voxel centres at whole numbers): what strokes
//! files store (`interfaces.md`). A *screen point* is in the arranged picture
//! ([`SliceLayout::arrange_pixels`]), pixel centres at whole numbers, x to the right, y down.
//! [`SliceLayout::screen_from_image`] and [`SliceLayout::image_from_screen`] convert exactly
//! (an affine map taking voxel centres to pixel centres), so a lasso drawn on screen and
//! stored in image points selects the voxels it was drawn around.
//!
//! Without an orientation ("orientation unknown"): the stored order (image axes as they are,
//! nothing flipped), no plane kind and no letters; the panels keep today's axes z, y, x.
//!
//! Never: resamples, rotates by other than quarter turns, or changes stored data.

use super::Axis;
use crate::volume::{PatientDirection, PatientOrientation};

/// The three standard planes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PlaneKind {
    /// Transverse: normal to the head-foot axis, seen from the feet.
    Axial,
    /// Normal to the front-back axis, seen from the front.
    Coronal,
    /// Normal to the left-right axis, seen from the patient's left.
    Sagittal,
}

impl PlaneKind {
    /// The order of the work screen's panels.
    pub const ALL: [PlaneKind; 3] = [PlaneKind::Axial, PlaneKind::Coronal, PlaneKind::Sagittal];

    /// "Axial", "Coronal", "Sagittal".
    pub fn name(self) -> &'static str {
        match self {
            PlaneKind::Axial => "Axial",
            PlaneKind::Coronal => "Coronal",
            PlaneKind::Sagittal => "Sagittal",
        }
    }

    /// The LPS axis normal to the plane: superior-inferior, posterior-anterior, left-right.
    fn normal_lps_axis(self) -> usize {
        match self {
            PlaneKind::Axial => 2,
            PlaneKind::Coronal => 1,
            PlaneKind::Sagittal => 0,
        }
    }

    /// The patient directions that screen-right and screen-down point to (module doc).
    pub fn screen_right_and_down(self) -> (PatientDirection, PatientDirection) {
        match self {
            PlaneKind::Axial => (PatientDirection::Left, PatientDirection::Posterior),
            PlaneKind::Coronal => (PatientDirection::Left, PatientDirection::Inferior),
            PlaneKind::Sagittal => (PatientDirection::Posterior, PatientDirection::Inferior),
        }
    }
}

/// The patient letters at a panel's four edges (DICOM letters, e.g. "R" on the left).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeLetters {
    /// Letter of the direction at the panel's left edge.
    pub left: &'static str,
    /// Letter at the right edge.
    pub right: &'static str,
    /// Letter at the top edge.
    pub top: &'static str,
    /// Letter at the bottom edge.
    pub bottom: &'static str,
}

/// How the slices normal to one voxel axis lie on the screen (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SliceLayout {
    /// The voxel axis normal to the slices.
    pub axis: Axis,
    /// The plane the slices are nearest to; `None` when the orientation is unknown.
    pub plane: Option<PlaneKind>,
    /// The voxel axis (0, 1, 2 for x, y, z) that runs left to right on screen.
    pub across_axis: usize,
    /// True when that axis's index decreases from left to right.
    pub across_reversed: bool,
    /// The voxel axis that runs top to bottom on screen.
    pub down_axis: usize,
    /// True when that axis's index decreases downwards.
    pub down_reversed: bool,
    /// The letters at the panel's edges; `None` when the orientation is unknown.
    pub edge_letters: Option<EdgeLetters>,
}

/// The voxel axes normal to the axial, coronal and sagittal planes, in that order (the work
/// screen's panels). Without an orientation: z, y, x, the stored order.
pub fn plane_axes(orientation: Option<&PatientOrientation>) -> [Axis; 3] {
    let Some(orientation) = orientation else {
        return [Axis::Z, Axis::Y, Axis::X];
    };
    let directions = orientation.anatomical_axes();
    PlaneKind::ALL.map(|plane| {
        let position =
            directions.iter().position(|d| d.lps_axis().0 == plane.normal_lps_axis()).unwrap_or(2 - plane as usize);
        Axis::ALL[position]
    })
}

impl SliceLayout {
    /// The layout of slices normal to `axis` of a volume with `orientation`.
    pub fn new(orientation: Option<&PatientOrientation>, axis: Axis) -> SliceLayout {
        let [column_axis, row_axis] = axis.image_axes();
        let stored = SliceLayout {
            axis,
            plane: None,
            across_axis: column_axis,
            across_reversed: false,
            down_axis: row_axis,
            down_reversed: false,
            edge_letters: None,
        };
        let Some(orientation) = orientation else {
            return stored;
        };
        let directions = orientation.anatomical_axes();
        let plane = match directions[axis.position()].lps_axis().0 {
            2 => PlaneKind::Axial,
            1 => PlaneKind::Coronal,
            _ => PlaneKind::Sagittal,
        };
        let (right, down) = plane.screen_right_and_down();
        // The in-plane voxel axis along a patient axis, and whether it runs the other way.
        let along = |wanted: PatientDirection| {
            let axis = [column_axis, row_axis]
                .into_iter()
                .find(|&a| directions[a].lps_axis().0 == wanted.lps_axis().0)
                .unwrap_or(column_axis);
            (axis, directions[axis] != wanted)
        };
        let ((across_axis, across_reversed), (down_axis, down_reversed)) = (along(right), along(down));
        if across_axis == down_axis {
            // Unreachable with one patient axis per voxel axis; the stored order is safe.
            return stored;
        }
        SliceLayout {
            axis,
            plane: Some(plane),
            across_axis,
            across_reversed,
            down_axis,
            down_reversed,
            edge_letters: Some(EdgeLetters {
                left: right.opposite().letter(),
                right: right.letter(),
                top: down.opposite().letter(),
                bottom: down.letter(),
            }),
        }
    }

    /// True when screen x runs along the image's rows' axis j (a quarter turn, not a flip).
    pub fn transposed(&self) -> bool {
        self.across_axis != self.axis.image_axes()[0]
    }

    /// The arranged picture's width and height in pixels for a volume of `dims`.
    pub fn screen_size(&self, dims: [usize; 3]) -> [usize; 2] {
        [dims[self.across_axis], dims[self.down_axis]]
    }

    /// The arranged picture's width and height in millimetres (for its aspect ratio).
    pub fn screen_extent_mm(&self, dims: [usize; 3], spacing_mm: [f64; 3]) -> [f64; 2] {
        let extent = |axis: usize| dims[axis] as f64 * spacing_mm[axis];
        [extent(self.across_axis), extent(self.down_axis)]
    }

    /// The screen point of image point `point` on a slice of a volume of `dims`.
    pub fn screen_from_image(&self, point: [f64; 2], dims: [usize; 3]) -> [f64; 2] {
        let (across, down) = if self.transposed() { (point[1], point[0]) } else { (point[0], point[1]) };
        [
            flip(across, dims[self.across_axis], self.across_reversed),
            flip(down, dims[self.down_axis], self.down_reversed),
        ]
    }

    /// The image point (what a strokes file stores) under screen point `point`; the inverse of
    /// [`SliceLayout::screen_from_image`].
    pub fn image_from_screen(&self, point: [f64; 2], dims: [usize; 3]) -> [f64; 2] {
        let across = flip(point[0], dims[self.across_axis], self.across_reversed);
        let down = flip(point[1], dims[self.down_axis], self.down_reversed);
        if self.transposed() { [down, across] } else { [across, down] }
    }

    /// The continuous voxel coordinates (x, y, z) under screen point `point` on slice `slice`.
    pub fn voxel_from_screen(&self, point: [f64; 2], dims: [usize; 3], slice: usize) -> [f64; 3] {
        let image = self.image_from_screen(point, dims);
        let [column_axis, row_axis] = self.axis.image_axes();
        let mut voxel = [0.0; 3];
        voxel[column_axis] = image[0];
        voxel[row_axis] = image[1];
        voxel[self.axis.position()] = slice as f64;
        voxel
    }

    /// The picture of a slice image as the screen shows it: `pixels` is the image (row-major,
    /// `width` x `height` as [`super::slice_image`] makes it, `bytes_per_pixel` bytes each:
    /// 1 grey, 3 RGB, 4 RGBA); returns the arranged pixels with their width and height.
    /// `None` when `pixels` does not hold `width * height` pixels.
    pub fn arrange_pixels(
        &self,
        pixels: &[u8],
        bytes_per_pixel: usize,
        width: usize,
        height: usize,
    ) -> Option<(Vec<u8>, usize, usize)> {
        if pixels.len() != width.checked_mul(height)?.checked_mul(bytes_per_pixel)? {
            return None;
        }
        let (screen_width, screen_height) = if self.transposed() { (height, width) } else { (width, height) };
        // Image index steps per screen pixel: one of them is ±1, the other ±width.
        let step = |reversed: bool, stride: isize| if reversed { -stride } else { stride };
        let (across_stride, down_stride) = if self.transposed() { (width as isize, 1) } else { (1, width as isize) };
        let across_step = step(self.across_reversed, across_stride);
        let down_step = step(self.down_reversed, down_stride);
        let start = (if self.across_reversed { (screen_width as isize - 1) * across_stride } else { 0 })
            + (if self.down_reversed { (screen_height as isize - 1) * down_stride } else { 0 });
        let mut arranged = Vec::with_capacity(pixels.len());
        for v in 0..screen_height as isize {
            let row_start = start + v * down_step;
            for u in 0..screen_width as isize {
                let index = (row_start + u * across_step) as usize * bytes_per_pixel;
                arranged.extend_from_slice(&pixels[index..index + bytes_per_pixel]);
            }
        }
        Some((arranged, screen_width, screen_height))
    }
}

/// `coordinate` along an axis of `count` voxels, mirrored about the axis's middle when
/// `reversed` (voxel centre k becomes count - 1 - k).
fn flip(coordinate: f64, count: usize, reversed: bool) -> f64 {
    if reversed { (count as f64 - 1.0) - coordinate } else { coordinate }
}

#[cfg(test)]
mod tests;
