//! Slices of a volume: which ones to show (paper §3.1, eq. 1) and how they look.
//!
//! A *slice* is the plane of voxels with one index fixed along an [`Axis`] (the axis normal to
//! it). [`slice_entropies`] ranks the slices of every axis by the entropy of their intensity
//! histogram in one parallel pass over the volume; [`foreground_slice_entropies`] ranks by the
//! entropy of the foreground (the body) and puts slices inside it first, and its top slice of
//! each axis is what the user lassos on. [`slice_image`] turns a slice into grey pixels through
//! a [`DisplayWindow`].
//!
//! Slice image axes (`interfaces.md`): for axis z the image is (x, y), for y it is (x, z), for x
//! it is (y, z); pixel (i, j) is the voxel whose centre is at image coordinates (i, j), stored
//! row-major (row j). [`SliceGeometry`] maps between the two.
//!
//! How slices lie on the screen (radiological convention, edge letters, screen <-> image
//! points) is [`SliceLayout`] with [`plane_axes`]; the 3-D view's anterior home position is
//! [`HomeView`]. Both read the volume's patient orientation.
//!
//! Never: draws on the image, knows about classes or strokes, or copies the volume.

mod display;
mod entropy;
mod foreground;
mod home_view;
mod layout;

pub use display::{DisplayWindow, GreyImage, looks_like_ct, slice_image};
pub use entropy::{ENTROPY_BINS, EntropyBinning, RankedSlices, SliceEntropies, entropy_nats, slice_entropies};
pub use foreground::{
    EDGE_FRACTION, EXTENT_MIN_FRACTION, central_band, foreground_extent, foreground_slice_entropies,
    foreground_slice_entropies_above,
};
pub use home_view::HomeView;
pub use layout::{EdgeLetters, PlaneKind, SliceLayout, plane_axes};

use serde::{Deserialize, Serialize};

/// An axis of the volume; for a slice, the axis normal to it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// The volume's x axis (the fastest-varying index in storage).
    X,
    /// The volume's y axis.
    Y,
    /// The volume's z axis (the slice axis of a stacked scan).
    Z,
}

impl Axis {
    /// The three axes in x, y, z order.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// 0, 1, 2 for x, y, z: the position of this axis in `dims` and `spacing_mm`.
    pub fn position(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// The lowercase name used in files ("x", "y", "z").
    pub fn name(self) -> &'static str {
        match self {
            Axis::X => "x",
            Axis::Y => "y",
            Axis::Z => "z",
        }
    }

    /// Parses "x", "y" or "z".
    pub fn from_name(name: &str) -> Option<Axis> {
        Axis::ALL.into_iter().find(|a| a.name() == name)
    }

    /// The volume axes that run along the slice image's columns (i) and rows (j).
    pub fn image_axes(self) -> [usize; 2] {
        match self {
            Axis::Z => [0, 1],
            Axis::Y => [0, 2],
            Axis::X => [1, 2],
        }
    }
}

impl std::fmt::Display for Axis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How one slice of a volume with `dims` lies in the volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SliceGeometry {
    /// The axis normal to the slice.
    pub axis: Axis,
    /// The slice's index along `axis`.
    pub slice: usize,
    /// Image width in pixels (voxels along the image's first axis).
    pub width: usize,
    /// Image height in pixels (voxels along the image's second axis).
    pub height: usize,
    /// Volume index of pixel (0, 0), and the index steps of one pixel along i and along j.
    origin_index: usize,
    step_i: usize,
    step_j: usize,
}

impl SliceGeometry {
    /// The geometry of slice `slice` along `axis`, or `None` when the slice is outside `dims`.
    pub fn new(dims: [usize; 3], axis: Axis, slice: usize) -> Option<SliceGeometry> {
        if slice >= dims[axis.position()] {
            return None;
        }
        let strides = [1, dims[0], dims[0] * dims[1]];
        let [column_axis, row_axis] = axis.image_axes();
        Some(SliceGeometry {
            axis,
            slice,
            width: dims[column_axis],
            height: dims[row_axis],
            origin_index: slice * strides[axis.position()],
            step_i: strides[column_axis],
            step_j: strides[row_axis],
        })
    }

    /// The volume index of pixel (i, j); `i < width`, `j < height`.
    #[inline]
    pub fn voxel_index(&self, i: usize, j: usize) -> usize {
        self.origin_index + i * self.step_i + j * self.step_j
    }

    /// The volume indices of row `j`, pixels `i_start..i_end`, in increasing order.
    pub fn row_indices(&self, j: usize, i_start: usize, i_end: usize) -> impl Iterator<Item = usize> {
        let base = self.origin_index + j * self.step_j;
        let step = self.step_i;
        (i_start..i_end).map(move |i| base + i * step)
    }
}

/// The one error type of the slice stage.
#[derive(Debug, thiserror::Error)]
pub enum SliceError {
    #[error("slice {slice} along {axis} is outside the volume, which has {slice_count} slices along {axis}")]
    /// A slice index is at or past the number of slices along its axis.
    SliceOutOfRange {
        /// The axis normal to the slice.
        axis: Axis,
        /// The index asked for.
        slice: usize,
        /// Number of slices along that axis.
        slice_count: usize,
    },
}

/// Number of slices along `axis`.
pub fn slice_count(dims: [usize; 3], axis: Axis) -> usize {
    dims[axis.position()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_names_round_trip_through_serde_in_lowercase() {
        for axis in Axis::ALL {
            let json = serde_json::to_string(&axis).unwrap();
            assert_eq!(json, format!("\"{}\"", axis.name()));
            assert_eq!(serde_json::from_str::<Axis>(&json).unwrap(), axis);
            assert_eq!(Axis::from_name(axis.name()), Some(axis));
        }
        assert!(serde_json::from_str::<Axis>("\"X\"").is_err());
        assert_eq!(Axis::from_name("w"), None);
    }

    #[test]
    fn slice_geometry_follows_the_interface_conventions() {
        let dims = [4, 5, 6];
        let index = |x: usize, y: usize, z: usize| x + 4 * (y + 5 * z);
        let z = SliceGeometry::new(dims, Axis::Z, 3).unwrap();
        assert_eq!((z.width, z.height), (4, 5));
        assert_eq!(z.voxel_index(2, 1), index(2, 1, 3));
        let y = SliceGeometry::new(dims, Axis::Y, 2).unwrap();
        assert_eq!((y.width, y.height), (4, 6));
        assert_eq!(y.voxel_index(3, 5), index(3, 2, 5));
        let x = SliceGeometry::new(dims, Axis::X, 1).unwrap();
        assert_eq!((x.width, x.height), (5, 6));
        assert_eq!(x.voxel_index(4, 2), index(1, 4, 2));
        assert_eq!(x.row_indices(2, 1, 3).collect::<Vec<_>>(), vec![index(1, 1, 2), index(1, 2, 2)]);
        assert!(SliceGeometry::new(dims, Axis::X, 4).is_none());
        assert!(SliceGeometry::new(dims, Axis::Z, 5).is_some());
    }
}
