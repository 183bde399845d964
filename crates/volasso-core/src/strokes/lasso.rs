//! Lasso polygons to voxels: the even-odd rule on voxel centres, by scanlines.
//!
//! Every pixel row j of the slice image is a horizontal line y = j. An edge (a, b) crosses it
//! when exactly one end lies above the line (`(a.y > j) != (b.y > j)`, the half-open rule of the
//! standard ray-crossing test, which counts a vertex on the line once). A pixel centre (i, j) is
//! inside when an odd number of crossings lie at or left of it, i.e. it falls in
//! `[c0, c1), [c2, c3), ...` of the row's sorted crossings. Each edge is visited only for the
//! rows it spans, so the cost is edges + crossings + selected voxels, not pixels x edges; the
//! rows are swept one at a time, so the memory is the edges and one row's crossings, never
//! every crossing at once ([`row_crossings`] counts them beforehand, for a caller that bounds
//! the work).
//!
//! The crossing of an edge is always computed from its lower end, so a polygon, its reverse and
//! any rotation of its point list produce the very same crossings and select the same voxels.
//! Self-intersecting polygons follow the even-odd rule (a bow-tie selects both triangles).
//! Fewer than 3 points, non-finite points or a slice outside the volume select nothing; a
//! polygon without area (all points on a line) selects nothing, because runs narrower than a
//! rounding error are dropped. Points off the slice are fine: rows and columns are clipped to
//! the slice, so only voxels inside the volume are selected.

use super::Lasso;
use crate::slices::SliceGeometry;

/// Runs narrower than this (relative to the largest coordinate) are rounding noise.
const RELATIVE_RUN_TOLERANCE: f64 = 1e-9;

impl Lasso {
    /// The volume indices (x fastest) of the voxels this lasso selects in a volume of `dims`,
    /// sorted and unique.
    pub fn selected_voxels(&self, dims: [usize; 3]) -> Vec<usize> {
        let Some(geometry) = SliceGeometry::new(dims, self.axis, self.slice) else {
            return Vec::new();
        };
        let mut voxels = Vec::new();
        polygon_rows(&self.points, geometry.width, geometry.height, |j, i_start, i_end| {
            voxels.extend(geometry.row_indices(j, i_start, i_end));
        });
        voxels
    }
}

/// Calls `run(j, i_start, i_end)` for each run of pixels `i_start..i_end` of row `j` whose centres
/// lie inside the closed polygon `points` (even-odd rule), in a `width x height` image; rows in
/// increasing order, runs left to right, never empty, never outside the image.
///
/// Rows are swept one at a time with the edges that span them, so the memory is the edges and
/// one row's crossings, and the time [`row_crossings`] (each sorted within its row).
pub fn polygon_rows(points: &[[f64; 2]], width: usize, height: usize, mut run: impl FnMut(usize, usize, usize)) {
    if points.len() < 3 || width == 0 || height == 0 {
        return;
    }
    if points.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
        return;
    }
    let largest_coordinate = points.iter().flat_map(|p| [p[0].abs(), p[1].abs()]).fold(1.0f64, f64::max);
    let tolerance = RELATIVE_RUN_TOLERANCE * largest_coordinate;
    let mut edges: Vec<Edge> = edges_in_rows(points, height).collect();
    edges.sort_unstable_by_key(|edge| edge.first_row);
    let right_edge = width as f64;
    let mut waiting = edges.into_iter().peekable();
    let mut active: Vec<Edge> = Vec::new();
    let mut crossings: Vec<f64> = Vec::new();
    let mut j = 0;
    loop {
        if active.is_empty() {
            // Skip the rows no edge spans.
            match waiting.peek() {
                Some(edge) => j = j.max(edge.first_row),
                None => return,
            }
        }
        if j >= height {
            return;
        }
        // An edge joins at its first row (first_row < high.y) and leaves after its last.
        while let Some(edge) = waiting.next_if(|edge| edge.first_row <= j) {
            active.push(edge);
        }
        crossings.clear();
        crossings.extend(active.iter().map(|edge| edge.low[0] + (j as f64 - edge.low[1]) * edge.slope));
        crossings.sort_unstable_by(f64::total_cmp);
        for pair in crossings.chunks_exact(2) {
            let (enter, leave) = (pair[0], pair[1]);
            if leave - enter <= tolerance {
                continue;
            }
            // Centres i with enter <= i < leave, clipped to 0..width.
            let i_start = enter.max(0.0).ceil().min(right_edge) as usize;
            let i_end = leave.max(0.0).ceil().min(right_edge) as usize;
            if i_start < i_end {
                run(j, i_start, i_end);
            }
        }
        active.retain(|edge| ((j + 1) as f64) < edge.high[1]);
        j += 1;
    }
}

/// How many (edge, row) crossings rasterising `points` in an image of `height` rows computes:
/// the work of [`polygon_rows`], found in one pass over the points. A loop a hand draws crosses
/// about twice as many rows as it is tall; one that zig-zags across the image crosses every
/// row with every edge.
pub fn row_crossings(points: &[[f64; 2]], height: usize) -> u64 {
    if points.len() < 3 || points.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
        return 0;
    }
    edges_in_rows(points, height)
        .map(|edge| {
            // Rows j with first_row <= j < high.y and j < height.
            let end = edge.high[1].ceil().min(height as f64) as u64;
            end.saturating_sub(edge.first_row as u64)
        })
        .sum()
}

/// How many pixels of a `width x height` image the bounding box of `points` covers: at least
/// as many as the polygon selects, found in one pass over the points.
pub fn bounding_pixels(points: &[[f64; 2]], width: usize, height: usize) -> u64 {
    if points.len() < 3 || points.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
        return 0;
    }
    let span = |coordinate: usize, size: usize| {
        let (low, high) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), p| {
            (low.min(p[coordinate]), high.max(p[coordinate]))
        });
        // Centres i with low <= i <= high, clipped to 0..size.
        let first = low.max(0.0).ceil().min(size as f64) as u64;
        let last = (high.floor() + 1.0).max(0.0).min(size as f64) as u64;
        last.saturating_sub(first)
    };
    span(0, width).saturating_mul(span(1, height))
}

/// An edge of a polygon that crosses at least one row of the image, from its lower end.
struct Edge {
    /// The lower end (smaller y).
    low: [f64; 2],
    /// The upper end.
    high: [f64; 2],
    /// dx / dy.
    slope: f64,
    /// The first image row it crosses: `low.y <= row < high.y`.
    first_row: usize,
}

/// The edges of the closed polygon `points` that cross a row of an image of `height` rows.
fn edges_in_rows(points: &[[f64; 2]], height: usize) -> impl Iterator<Item = Edge> + '_ {
    let last_row = height.saturating_sub(1) as f64;
    points.iter().enumerate().filter_map(move |(k, &a)| {
        let b = points[(k + 1) % points.len()];
        if a[1] == b[1] || height == 0 {
            return None; // horizontal edges never cross a row by the half-open rule
        }
        let (low, high) = if a[1] < b[1] { (a, b) } else { (b, a) };
        // Rows j with low.y <= j < high.y, clipped to the image.
        let first = low[1].max(0.0).ceil();
        if first > last_row || first >= high[1] {
            return None;
        }
        // The crossing of an edge is always computed from its lower end, so a polygon, its
        // reverse and any rotation of its point list give the very same crossings.
        let slope = (high[0] - low[0]) / (high[1] - low[1]);
        Some(Edge { low, high, slope, first_row: first as usize })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slices::Axis;
    use proptest::prelude::*;

    fn lasso(axis: Axis, slice: usize, points: &[[f64; 2]]) -> Lasso {
        Lasso { axis, slice, points: points.to_vec() }
    }

    /// The pixels (i, j) selected in a `width x height` image, by brute force: the textbook
    /// ray-crossing test (W. R. Franklin's pnpoly) on every pixel centre.
    fn brute_force(points: &[[f64; 2]], width: usize, height: usize) -> Vec<(usize, usize)> {
        let mut inside = Vec::new();
        for j in 0..height {
            for i in 0..width {
                let (x, y) = (i as f64, j as f64);
                let mut odd = false;
                for k in 0..points.len() {
                    let a = points[k];
                    let b = points[(k + 1) % points.len()];
                    if (a[1] > y) != (b[1] > y) {
                        let (low, high) = if a[1] < b[1] { (a, b) } else { (b, a) };
                        let crossing = low[0] + (y - low[1]) * (high[0] - low[0]) / (high[1] - low[1]);
                        if x >= crossing {
                            odd = !odd;
                        }
                    }
                }
                if odd {
                    inside.push((i, j));
                }
            }
        }
        inside
    }

    fn scanline(points: &[[f64; 2]], width: usize, height: usize) -> Vec<(usize, usize)> {
        let mut pixels = Vec::new();
        polygon_rows(points, width, height, |j, start, end| pixels.extend((start..end).map(|i| (i, j))));
        pixels.sort_by_key(|&(i, j)| (j, i));
        pixels
    }

    #[test]
    fn a_square_selects_exactly_the_centres_inside() {
        // Square [1.5, 4.5] x [2.5, 5.5] on z slice 1 of a 8 x 8 x 3 volume: x 2..=4, y 3..=5.
        let square = lasso(Axis::Z, 1, &[[1.5, 2.5], [4.5, 2.5], [4.5, 5.5], [1.5, 5.5]]);
        let mut expected = Vec::new();
        for y in 3..=5 {
            for x in 2..=4 {
                expected.push(x + 8 * (y + 8));
            }
        }
        assert_eq!(square.selected_voxels([8, 8, 3]), expected);
        // Edges through centres: the half-open rule takes the low side, not the high side.
        let on_centres = lasso(Axis::Z, 0, &[[1.0, 1.0], [3.0, 1.0], [3.0, 3.0], [1.0, 3.0]]);
        let expected: Vec<usize> = [(1, 1), (2, 1), (1, 2), (2, 2)].iter().map(|&(x, y)| x + 8 * y).collect();
        assert_eq!(on_centres.selected_voxels([8, 8, 3]), expected);
    }

    #[test]
    fn squares_on_x_and_y_slices_map_to_the_right_voxels() {
        let dims = [5, 6, 7];
        let index = |x: usize, y: usize, z: usize| x + 5 * (y + 6 * z);
        let on_y = lasso(Axis::Y, 4, &[[0.5, 1.5], [1.5, 1.5], [1.5, 2.5], [0.5, 2.5]]);
        assert_eq!(on_y.selected_voxels(dims), vec![index(1, 4, 2)]);
        let on_x = lasso(Axis::X, 3, &[[4.5, 5.5], [5.5, 5.5], [5.5, 6.5], [4.5, 6.5]]);
        assert_eq!(on_x.selected_voxels(dims), vec![index(3, 5, 6)]);
    }

    #[test]
    fn a_bow_tie_selects_both_triangles_by_the_even_odd_rule() {
        // Crossing at (5, 5): left triangle opens to the left edge, right one to the right.
        let bow_tie = [[0.0, 0.0], [10.0, 10.0], [10.0, 0.0], [0.0, 10.0]];
        let pixels = scanline(&bow_tie, 12, 12);
        assert_eq!(pixels, brute_force(&bow_tie, 12, 12));
        assert!(pixels.contains(&(1, 5)) && pixels.contains(&(9, 5)));
        assert!(!pixels.contains(&(5, 2)) && !pixels.contains(&(5, 8)));
        // A pentagram: the centre pentagon is crossed twice, so it is outside.
        let star: Vec<[f64; 2]> = (0..5)
            .map(|k| {
                let angle = std::f64::consts::PI * (0.5 + 0.8 * k as f64);
                [20.0 + 15.0 * angle.cos(), 20.0 + 15.0 * angle.sin()]
            })
            .collect();
        let pixels = scanline(&star, 40, 40);
        assert_eq!(pixels, brute_force(&star, 40, 40));
        assert!(!pixels.contains(&(20, 20)));
        assert!(pixels.contains(&(20, 33)));
    }

    #[test]
    fn degenerate_lassos_select_nothing() {
        let dims = [10, 10, 10];
        for points in [
            vec![],
            vec![[3.0, 3.0]],
            vec![[1.0, 1.0], [8.0, 8.0]],
            vec![[1.0, 1.0], [4.0, 4.0], [8.0, 8.0]],
            vec![[1.0, 1.0], [8.0, 8.0], [1.0, 1.0], [5.0, 5.0]],
            vec![[0.1, 0.17], [7.3, 5.21], [2.9, 2.13]], // on y = 0.7 x + 0.1, inexact in binary
            vec![[2.0, 5.0], [9.0, 5.0], [4.0, 5.0]],
            vec![[3.0, 3.0], [3.0, 3.0], [3.0, 3.0]],
            vec![[1.0, f64::NAN], [8.0, 8.0], [1.0, 8.0]],
            vec![[1.0, f64::INFINITY], [8.0, 8.0], [1.0, 8.0]],
        ] {
            assert!(lasso(Axis::Z, 2, &points).selected_voxels(dims).is_empty(), "{points:?}");
        }
        let square = [[1.5, 1.5], [4.5, 1.5], [4.5, 4.5], [1.5, 4.5]];
        assert!(lasso(Axis::Z, 10, &square).selected_voxels(dims).is_empty());
        // Coordinates at the edge of f64 overflow the slope: no panic, nothing outside.
        let huge = [[-1e308, -1e308], [1e308, -1e308], [0.0, 1e308], [f64::MAX, f64::MIN]];
        assert!(lasso(Axis::Z, 2, &huge).selected_voxels(dims).iter().all(|&v| v < 1000));
    }

    #[test]
    fn points_off_the_slice_are_clipped_to_it() {
        let dims = [6, 4, 2];
        let everything = lasso(Axis::Z, 1, &[[-100.0, -50.0], [1e6, -50.0], [1e6, 1e9], [-100.0, 1e9]]);
        let expected: Vec<usize> = (24..48).collect();
        assert_eq!(everything.selected_voxels(dims), expected);
        let outside = lasso(Axis::Z, 0, &[[-9.0, -9.0], [-1.0, -9.0], [-1.0, -1.0]]);
        assert!(outside.selected_voxels(dims).is_empty());
        let below = lasso(Axis::Z, 0, &[[0.0, 4.5], [5.0, 4.5], [5.0, 9.0]]);
        assert!(below.selected_voxels(dims).is_empty());
    }

    #[test]
    fn a_many_point_circle_selects_what_brute_force_does() {
        let circle: Vec<[f64; 2]> = (0..2000)
            .map(|k| {
                let angle = k as f64 * std::f64::consts::TAU / 2000.0;
                [60.3 + 50.0 * angle.cos(), 70.7 + 45.0 * angle.sin()]
            })
            .collect();
        let pixels = scanline(&circle, 128, 128);
        assert_eq!(pixels, brute_force(&circle, 128, 128));
        let area = std::f64::consts::PI * 50.0 * 45.0;
        assert!((pixels.len() as f64 - area).abs() < 0.01 * area);
    }

    fn polygon_strategy() -> impl Strategy<Value = Vec<[f64; 2]>> {
        prop::collection::vec(prop::array::uniform2(-8.0f64..40.0), 0..12)
    }

    proptest! {
        #[test]
        fn selection_stays_inside_the_volume_and_matches_brute_force(
            points in polygon_strategy(),
            axis in prop::sample::select(Axis::ALL.to_vec()),
        ) {
            let dims = [23, 17, 29];
            let slice = dims[axis.position()] / 2;
            let voxels = lasso(axis, slice, &points).selected_voxels(dims);
            let geometry = SliceGeometry::new(dims, axis, slice).unwrap();
            prop_assert!(voxels.windows(2).all(|w| w[0] < w[1]));
            let count = dims.iter().product::<usize>();
            prop_assert!(voxels.iter().all(|&v| v < count));
            let on_slice = |v: usize| [v % 23, (v / 23) % 17, v / (23 * 17)][axis.position()] == slice;
            prop_assert!(voxels.iter().all(|&v| on_slice(v)));
            if points.len() >= 3 {
                let expected = brute_force(&points, geometry.width, geometry.height);
                // Brute force has no rounding tolerance; it may only add zero-width slivers.
                let pixels = scanline(&points, geometry.width, geometry.height);
                prop_assert!(pixels.iter().all(|p| expected.contains(p)));
                prop_assert!(expected.len() - pixels.len() <= 2 * geometry.height);
                prop_assert_eq!(pixels.len(), voxels.len());
            }
        }

        #[test]
        fn the_work_and_the_bounding_box_are_counted_beforehand(
            points in polygon_strategy(),
        ) {
            let (width, height) = (23, 17);
            // The half-open rule's crossings, edge by edge and row by row.
            let counted: u64 = (0..height)
                .map(|j| {
                    let y = j as f64;
                    (0..points.len())
                        .filter(|&k| (points[k][1] > y) != (points[(k + 1) % points.len()][1] > y))
                        .count() as u64
                })
                .sum();
            let expected = if points.len() < 3 { 0 } else { counted };
            prop_assert_eq!(row_crossings(&points, height), expected);
            let selected = scanline(&points, width, height).len() as u64;
            prop_assert!(bounding_pixels(&points, width, height) >= selected);
        }

        #[test]
        fn points_on_one_line_select_nothing(
            origin in prop::array::uniform2(-5.0f64..35.0),
            direction in prop::array::uniform2(-3.0f64..3.0),
            steps in prop::collection::vec(-10.0f64..10.0, 3..8),
        ) {
            let points: Vec<[f64; 2]> = steps
                .iter()
                .map(|t| [origin[0] + t * direction[0], origin[1] + t * direction[1]])
                .collect();
            prop_assert!(lasso(Axis::Z, 0, &points).selected_voxels([30, 30, 1]).is_empty());
        }

        #[test]
        fn rotation_and_reversal_of_the_points_change_nothing(
            points in polygon_strategy(),
            shift in 0usize..12,
        ) {
            let dims = [30, 30, 3];
            let selected = lasso(Axis::Z, 1, &points).selected_voxels(dims);
            let mut rotated = points.clone();
            if !rotated.is_empty() {
                let by = shift % rotated.len();
                rotated.rotate_left(by);
            }
            prop_assert_eq!(&lasso(Axis::Z, 1, &rotated).selected_voxels(dims), &selected);
            let mut reversed = points.clone();
            reversed.reverse();
            prop_assert_eq!(&lasso(Axis::Z, 1, &reversed).selected_voxels(dims), &selected);
        }
    }
}
