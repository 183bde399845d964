//! Lassos drawn inside another class's lasso: which class a voxel that two classes select
//! belongs to (paper §3.2's free-form lassos, as a finger draws them).
//!
//! A user circles a cell and then, inside that loop, its nucleus; a bone and then its marrow; an
//! organ and then the lesion in it. The outer loop's polygon takes in the inner structure (the
//! even-odd rule fills it), so every voxel of the inner loop is selected by both classes. The
//! user meant the inner loop to say what those voxels are: a voxel selected by several classes
//! goes to the class whose loop lies *nested* in every other class's loop through it, on the
//! same slice. A loop is nested in another when at least [`NESTED_SHARE`] of its voxels lie in
//! the other and it has at most [`NESTED_SIZE_RATIO`] of the other's voxels, so two loops of
//! about one size that overlap where a finger leaked over a shared border are not nested, and
//! their common voxels stay contested (dropped from both, `super::training`). Only files a hand
//! draws are compared: in one with more than [`MAX_LOOPS_ON_A_SLICE`] loops on a slice, or whose
//! loops cover more than [`MAX_COMPARED_VOXELS`], every shared voxel stays contested, so a
//! crowded file cannot cost the square of its loops nor hold all their voxels at once.
//!
//! Never: reads files, or looks at the volume's values; loops become voxels through
//! [`super::Lasso::selected_voxels`], as for the training set.

use super::StrokesFile;
use super::lasso::bounding_pixels;
use crate::slices::{Axis, SliceGeometry};

/// A loop is nested in another when at least this share of its voxels lies in the other: a
/// finger's inner loop drawn close to the outer one's edge may cross it for a voxel or two.
pub const NESTED_SHARE: f64 = 0.8;

/// ... and when it has at most this fraction of the other's voxels: an inner structure drawn
/// inside an outer one is the smaller; two loops of about one size are neighbours that overlap.
pub const NESTED_SIZE_RATIO: f64 = 0.5;

/// Loops on one slice compared with each other at most: a hand draws a few; a file with more
/// on a slice (a script's, or a hostile one) would cost their number squared, and its shared
/// voxels all stay contested.
pub const MAX_LOOPS_ON_A_SLICE: usize = 64;

/// The voxels of all loops held at once while comparing them, at most (their bounding boxes
/// counted): 32 Mi voxels, 256 MiB of indices. A file whose loops cover more leaves every
/// shared voxel contested, as a crowded slice does.
pub const MAX_COMPARED_VOXELS: u64 = 1 << 25;

/// One drawn loop: its class (position in the strokes file), slice and voxels.
struct DrawnLoop {
    /// The class's position in the strokes file.
    class: usize,
    /// The slice it was drawn on.
    plane: (Axis, usize),
    /// Its voxels, sorted and unique.
    voxels: Vec<usize>,
}

/// For each of `contested` (voxels several classes select, sorted), the class whose loops
/// through it lie nested in every other class's loop through it, if there is one; `file`'s
/// lassos are rasterised again here, only when some voxel is contested, and not at all when a
/// slice holds more than [`MAX_LOOPS_ON_A_SLICE`] loops (then no voxel has an inner class).
pub(super) fn inner_classes(file: &StrokesFile, dims: [usize; 3], contested: &[usize]) -> Vec<Option<usize>> {
    if contested.is_empty() {
        return Vec::new();
    }
    let mut planes: Vec<(usize, usize)> = file
        .classes
        .iter()
        .flat_map(|class| class.strokes.iter())
        .map(|lasso| (lasso.axis.position(), lasso.slice))
        .collect();
    planes.sort_unstable();
    if let Some(crowded) = planes.chunk_by(|a, b| a == b).map(<[_]>::len).find(|&count| count > MAX_LOOPS_ON_A_SLICE) {
        log::warn!(
            "{crowded} loops on one slice: more than {MAX_LOOPS_ON_A_SLICE}, so no loop counts as drawn inside another"
        );
        return vec![None; contested.len()];
    }
    let covered: u64 = file
        .classes
        .iter()
        .flat_map(|class| class.strokes.iter())
        .filter_map(|lasso| {
            let geometry = SliceGeometry::new(dims, lasso.axis, lasso.slice)?;
            Some(bounding_pixels(&lasso.points, geometry.width, geometry.height))
        })
        .fold(0u64, u64::saturating_add);
    if covered > MAX_COMPARED_VOXELS {
        log::warn!(
            "the loops cover {covered} voxels: more than {MAX_COMPARED_VOXELS}, so no loop counts as drawn inside another"
        );
        return vec![None; contested.len()];
    }
    let loops: Vec<DrawnLoop> = file
        .classes
        .iter()
        .enumerate()
        .flat_map(|(class, strokes)| strokes.strokes.iter().map(move |lasso| (class, lasso)))
        .map(|(class, lasso)| DrawnLoop {
            class,
            plane: (lasso.axis, lasso.slice),
            voxels: lasso.selected_voxels(dims),
        })
        .collect();
    inner_classes_of(&loops, contested)
}

/// [`inner_classes`] of loops already rasterised.
fn inner_classes_of(loops: &[DrawnLoop], contested: &[usize]) -> Vec<Option<usize>> {
    let nested = nested_pairs(loops);
    if nested.is_empty() {
        return vec![None; contested.len()];
    }
    contested
        .iter()
        .map(|&voxel| {
            let through: Vec<usize> =
                (0..loops.len()).filter(|&k| loops[k].voxels.binary_search(&voxel).is_ok()).collect();
            let mut classes: Vec<usize> = through.iter().map(|&k| loops[k].class).collect();
            classes.sort_unstable();
            classes.dedup();
            let inside_every_other = |class: usize| {
                classes.iter().filter(|&&other| other != class).all(|&other| {
                    through.iter().any(|&inner| {
                        loops[inner].class == class
                            && through
                                .iter()
                                .any(|&outer| loops[outer].class == other && nested[inner].contains(&outer))
                    })
                })
            };
            let mut winners = classes.iter().copied().filter(|&class| inside_every_other(class));
            match (winners.next(), winners.next()) {
                (Some(class), None) => Some(class),
                _ => None,
            }
        })
        .collect()
}

/// For each loop, the loops of other classes on its slice that it lies nested in; empty when
/// none is.
fn nested_pairs(loops: &[DrawnLoop]) -> Vec<Vec<usize>> {
    let mut by_slice: Vec<usize> = (0..loops.len()).collect();
    by_slice.sort_by_key(|&k| (loops[k].plane.0.position(), loops[k].plane.1));
    let mut nested = vec![Vec::new(); loops.len()];
    let mut any = false;
    for slice in by_slice.chunk_by(|&a, &b| loops[a].plane == loops[b].plane) {
        for &inner in slice {
            for &outer in slice {
                if lies_inside(&loops[inner], &loops[outer]) {
                    nested[inner].push(outer);
                    any = true;
                }
            }
        }
    }
    if any { nested } else { Vec::new() }
}

/// Whether loop `small` lies nested in loop `large` of another class (module doc); stops as
/// soon as too many of its voxels lie outside.
fn lies_inside(small: &DrawnLoop, large: &DrawnLoop) -> bool {
    if small.class == large.class
        || small.voxels.is_empty()
        || small.voxels.len() as f64 > NESTED_SIZE_RATIO * large.voxels.len() as f64
    {
        return false;
    }
    let allowed_outside = ((1.0 - NESTED_SHARE) * small.voxels.len() as f64).floor() as usize;
    let mut outside = 0;
    for voxel in &small.voxels {
        if large.voxels.binary_search(voxel).is_err() {
            outside += 1;
            if outside > allowed_outside {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strokes::{ClassStrokes, Lasso};

    fn square(class: usize, slice: usize, from: usize, to: usize) -> DrawnLoop {
        let width = 100;
        let voxels =
            (from..=to).flat_map(|y| (from..=to).map(move |x| x + width * y + width * width * slice)).collect();
        DrawnLoop { class, plane: (Axis::Z, slice), voxels }
    }

    fn voxel(slice: usize, x: usize, y: usize) -> usize {
        x + 100 * y + 100 * 100 * slice
    }

    #[test]
    fn a_loop_inside_another_class_s_loop_takes_the_voxels_it_shares() {
        let loops = [square(0, 3, 0, 19), square(1, 3, 5, 9)];
        let contested = [voxel(3, 5, 5), voxel(3, 9, 9)];
        assert_eq!(inner_classes_of(&loops, &contested), vec![Some(1), Some(1)]);
        // The order of the classes does not matter.
        let swapped = [square(1, 3, 0, 19), square(0, 3, 5, 9)];
        assert_eq!(inner_classes_of(&swapped, &contested), vec![Some(0), Some(0)]);
    }

    #[test]
    fn loops_of_about_one_size_or_on_other_slices_are_not_nested() {
        // 10 x 10 and 8 x 8 overlapping: the smaller is not at most half the larger.
        let alike = [square(0, 3, 0, 9), square(1, 3, 2, 9)];
        assert_eq!(inner_classes_of(&alike, &[voxel(3, 5, 5)]), vec![None]);
        // Half of the small loop outside the large one: neighbours that overlap.
        let neighbours = [square(0, 3, 0, 19), square(1, 3, 15, 24)];
        assert_eq!(inner_classes_of(&neighbours, &[voxel(3, 16, 16)]), vec![None]);
        // Only loops on one slice are compared: the same voxels named on another slice are not.
        let mut other_slice = square(1, 3, 5, 9);
        other_slice.plane = (Axis::Z, 4);
        assert_eq!(inner_classes_of(&[square(0, 3, 0, 19), other_slice], &[voxel(3, 5, 5)]), vec![None]);
    }

    #[test]
    fn nesting_goes_any_number_of_levels_deep() {
        // A cell, its nucleus, and a nucleolus in the nucleus.
        let loops = [square(0, 2, 0, 39), square(1, 2, 10, 29), square(2, 2, 15, 19)];
        let contested = [voxel(2, 12, 12), voxel(2, 16, 16)];
        assert_eq!(inner_classes_of(&loops, &contested), vec![Some(1), Some(2)]);
    }

    #[test]
    fn a_voxel_of_two_inner_loops_of_different_classes_stays_contested() {
        // Two inner loops that overlap each other inside one outer loop: neither is nested in
        // the other, so their shared voxels have no inner class.
        let loops = [square(0, 1, 0, 39), square(1, 1, 5, 14), square(2, 1, 10, 19)];
        assert_eq!(inner_classes_of(&loops, &[voxel(1, 12, 12), voxel(1, 6, 6)]), vec![None, Some(1)]);
    }

    #[test]
    fn a_slice_with_more_loops_than_a_hand_draws_is_not_compared() {
        // One wide loop and, inside it, more small loops of another class than the limit.
        let square = |x: f64| Lasso {
            axis: Axis::Z,
            slice: 5,
            points: vec![[x, x], [x + 1.0, x], [x + 1.0, x + 1.0], [x, x + 1.0]],
        };
        let wide = Lasso { points: vec![[-0.5, -0.5], [99.5, -0.5], [99.5, 99.5], [-0.5, 99.5]], ..square(0.0) };
        let small: Vec<Lasso> = (0..MAX_LOOPS_ON_A_SLICE).map(|k| square(k as f64)).collect();
        let mut file = StrokesFile {
            classes: vec![
                ClassStrokes { name: "outer".into(), strokes: vec![wide] },
                ClassStrokes { name: "inner".into(), strokes: small },
            ],
        };
        let dims = [100, 100, 10];
        assert_eq!(inner_classes(&file, dims, &[voxel(5, 1, 1)]), vec![None]);
        file.classes[1].strokes.pop();
        assert_eq!(inner_classes(&file, dims, &[voxel(5, 1, 1)]), vec![Some(1)]);
    }
}
