//! A finger path on a slice picture, turned into what it meant: a lasso (a closed polygon in
//! voxel coordinates, the strokes file's convention), a horizontal swipe to the next- or
//! previous-ranked slice, or nothing (a tap or a scribble without area).
//!
//! Why geometry and not timing: a swipe is a nearly straight horizontal stroke, which encloses
//! almost no area, while a lasso is drawn to enclose some; the two are told apart the same way
//! whether the events come from a finger, a mouse or a replay script.
//!
//! Never: touches the UI or the volume.

use crate::slices::{Axis, SliceGeometry};
use crate::strokes::Lasso;

/// Points closer than this (as a fraction of the picture) to the previous one are dropped: a
/// finger resting on the glass sends many.
const MIN_STEP_FRACTION: f32 = 0.003;

/// A path keeps at most this many points, so a touch storm cannot grow it without bound.
pub const MAX_PATH_POINTS: usize = 4096;

/// A swipe spans at least this fraction of the picture's width...
const SWIPE_MIN_WIDTH: f32 = 0.25;
/// ...while staying within this fraction of its height...
const SWIPE_MAX_HEIGHT: f32 = 0.12;

/// A lasso must enclose at least this fraction of the picture (about a 3x3 voxel patch on a
/// 128-voxel slice); smaller ones are taps or slips.
const MIN_AREA_FRACTION: f32 = 0.0004;

/// The finger path on one slice picture, in fractions (0..1) of the picture's width and height.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FingerPath {
    pub points: Vec<[f32; 2]>,
}

/// What a finished path meant.
#[derive(Clone, Debug, PartialEq)]
pub enum PathMeaning {
    Lasso(Lasso),
    /// +1: to the next-ranked slice (a swipe to the left, like turning a page); -1: back.
    Swipe(i32),
    Nothing,
}

impl FingerPath {
    pub fn add(&mut self, fraction: [f32; 2]) {
        if !(fraction[0].is_finite() && fraction[1].is_finite()) || self.points.len() >= MAX_PATH_POINTS {
            return;
        }
        if let Some(last) = self.points.last() {
            let step = (fraction[0] - last[0]).abs().max((fraction[1] - last[1]).abs());
            if step < MIN_STEP_FRACTION {
                return;
            }
        }
        self.points.push(fraction);
    }

    /// The path as an SVG path in a 0..1000 box, closed while drawing so the user sees what
    /// the lasso will enclose.
    pub fn svg_commands(&self) -> String {
        let mut commands = String::with_capacity(self.points.len() * 14);
        for (k, [x, y]) in self.points.iter().enumerate() {
            let verb = if k == 0 { 'M' } else { 'L' };
            commands.push_str(&format!("{verb} {:.1} {:.1} ", x * 1000.0, y * 1000.0));
        }
        if self.points.len() > 2 {
            commands.push('Z');
        }
        commands
    }

    /// What the path meant on slice `slice` along `axis` of a volume of `dims`.
    pub fn meaning(&self, dims: [usize; 3], axis: Axis, slice: usize) -> PathMeaning {
        let Some(geometry) = SliceGeometry::new(dims, axis, slice) else {
            return PathMeaning::Nothing;
        };
        if self.points.len() < 2 {
            return PathMeaning::Nothing;
        }
        let (mut low, mut high) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for point in &self.points {
            for a in 0..2 {
                low[a] = low[a].min(point[a]);
                high[a] = high[a].max(point[a]);
            }
        }
        let (first, last) = (self.points[0], self.points[self.points.len() - 1]);
        if high[0] - low[0] >= SWIPE_MIN_WIDTH && high[1] - low[1] <= SWIPE_MAX_HEIGHT {
            return PathMeaning::Swipe(if last[0] < first[0] { 1 } else { -1 });
        }
        if self.points.len() < 3 || enclosed_area(&self.points) < MIN_AREA_FRACTION {
            return PathMeaning::Nothing;
        }
        // Voxel (i, j) has its centre at (i, j), so the picture spans -0.5 .. width - 0.5.
        let (width, height) = (geometry.width as f64, geometry.height as f64);
        let points =
            self.points.iter().map(|&[x, y]| [x as f64 * width - 0.5, y as f64 * height - 0.5]).collect::<Vec<_>>();
        PathMeaning::Lasso(Lasso { axis, slice, points })
    }
}

/// The area the closed path encloses (shoelace formula, absolute), in picture fractions.
fn enclosed_area(points: &[[f32; 2]]) -> f32 {
    let twice: f32 = points.iter().zip(points.iter().cycle().skip(1)).map(|(a, b)| a[0] * b[1] - b[0] * a[1]).sum();
    twice.abs() / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(points: &[[f32; 2]]) -> FingerPath {
        let mut path = FingerPath::default();
        for &point in points {
            path.add(point);
        }
        path
    }

    #[test]
    fn a_loop_becomes_a_lasso_in_voxel_coordinates() {
        let square = path(&[[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]]);
        let PathMeaning::Lasso(lasso) = square.meaning([100, 40, 10], Axis::Z, 3) else {
            panic!("not a lasso: {:?}", square.meaning([100, 40, 10], Axis::Z, 3));
        };
        assert_eq!((lasso.axis, lasso.slice), (Axis::Z, 3));
        assert_eq!(lasso.points[0], [24.5, 9.5]);
        assert_eq!(lasso.points[2], [74.5, 29.5]);
        // Half the width and half the height of a 100 x 40 slice: 50 x 20 voxels.
        assert_eq!(lasso.selected_voxels([100, 40, 10]).len(), 50 * 20);
    }

    #[test]
    fn a_flat_horizontal_stroke_is_a_swipe_with_a_direction() {
        let left = path(&[[0.8, 0.5], [0.5, 0.52], [0.2, 0.5]]);
        assert_eq!(left.meaning([64, 64, 64], Axis::X, 1), PathMeaning::Swipe(1));
        let right = path(&[[0.2, 0.5], [0.6, 0.48]]);
        assert_eq!(right.meaning([64, 64, 64], Axis::X, 1), PathMeaning::Swipe(-1));
    }

    #[test]
    fn taps_lines_and_tiny_loops_mean_nothing() {
        let dims = [64, 64, 64];
        assert_eq!(path(&[[0.5, 0.5]]).meaning(dims, Axis::Z, 0), PathMeaning::Nothing);
        assert_eq!(path(&[[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]]).meaning(dims, Axis::Z, 0), PathMeaning::Nothing);
        let tiny = path(&[[0.5, 0.5], [0.51, 0.5], [0.51, 0.51], [0.5, 0.51]]);
        assert_eq!(tiny.meaning(dims, Axis::Z, 0), PathMeaning::Nothing);
        let square = path(&[[0.2, 0.2], [0.6, 0.2], [0.6, 0.6]]);
        assert_eq!(square.meaning(dims, Axis::Z, 64), PathMeaning::Nothing, "slice outside the volume");
    }

    #[test]
    fn paths_are_bounded_and_ignore_non_finite_points() {
        let mut path = FingerPath::default();
        path.add([f32::NAN, 0.5]);
        assert!(path.points.is_empty());
        for k in 0..3 * MAX_PATH_POINTS {
            path.add([(k % 100) as f32 / 100.0, (k / 100) as f32 / 1000.0]);
        }
        assert_eq!(path.points.len(), MAX_PATH_POINTS);
        assert!(path.svg_commands().starts_with("M 0.0 0.0 L 10.0 0.0"));
        assert!(path.svg_commands().ends_with('Z'));
    }
}
