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
//! their common voxels stay contested (dropped from both, `super::training`).
//!
//! Never: reads files, rasterises polygons, or looks at the volume's values.

use crate::slices::Axis;

/// A loop is nested in another when at least this share of its voxels lies in the other: a
/// finger's inner loop drawn close to the outer one's edge may cross it for a voxel or two.
pub const NESTED_SHARE: f64 = 0.8;

/// ... and when it has at most this fraction of the other's voxels: an inner structure drawn
/// inside an outer one is the smaller; two loops of about one size are neighbours that overlap.
pub const NESTED_SIZE_RATIO: f64 = 0.5;

/// One drawn loop: its class (position in the strokes file), slice and voxels.
pub(super) struct DrawnLoop {
    /// The class's position in the strokes file.
    pub class: usize,
    /// The slice it was drawn on.
    pub plane: (Axis, usize),
    /// Its voxels, sorted and unique.
    pub voxels: Vec<usize>,
}

/// For each of `contested` (voxels several classes select, sorted), the class whose loops
/// through it lie nested in every other class's loop through it, if there is one.
pub(super) fn inner_classes(loops: &[DrawnLoop], contested: &[usize]) -> Vec<Option<usize>> {
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

/// For each loop, the loops of other classes on its slice that it lies nested in.
fn nested_pairs(loops: &[DrawnLoop]) -> Vec<Vec<usize>> {
    let mut nested = vec![Vec::new(); loops.len()];
    let mut any = false;
    for (inner, small) in loops.iter().enumerate() {
        for (outer, large) in loops.iter().enumerate() {
            let candidate = small.class != large.class
                && small.plane == large.plane
                && !small.voxels.is_empty()
                && small.voxels.len() as f64 <= NESTED_SIZE_RATIO * large.voxels.len() as f64;
            if candidate
                && shared_count(&small.voxels, &large.voxels) as f64 >= NESTED_SHARE * small.voxels.len() as f64
            {
                nested[inner].push(outer);
                any = true;
            }
        }
    }
    if any { nested } else { Vec::new() }
}

/// How many values two sorted, unique lists share.
fn shared_count(a: &[usize], b: &[usize]) -> usize {
    let (mut i, mut j, mut count) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                count += 1;
                i += 1;
                j += 1;
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(inner_classes(&loops, &contested), vec![Some(1), Some(1)]);
        // The order of the classes does not matter.
        let swapped = [square(1, 3, 0, 19), square(0, 3, 5, 9)];
        assert_eq!(inner_classes(&swapped, &contested), vec![Some(0), Some(0)]);
    }

    #[test]
    fn loops_of_about_one_size_or_on_other_slices_are_not_nested() {
        // 10 x 10 and 8 x 8 overlapping: the smaller is not at most half the larger.
        let alike = [square(0, 3, 0, 9), square(1, 3, 2, 9)];
        assert_eq!(inner_classes(&alike, &[voxel(3, 5, 5)]), vec![None]);
        // Half of the small loop outside the large one: neighbours that overlap.
        let neighbours = [square(0, 3, 0, 19), square(1, 3, 15, 24)];
        assert_eq!(inner_classes(&neighbours, &[voxel(3, 16, 16)]), vec![None]);
        // Only loops on one slice are compared: the same voxels named on another slice are not.
        let mut other_slice = square(1, 3, 5, 9);
        other_slice.plane = (Axis::Z, 4);
        assert_eq!(inner_classes(&[square(0, 3, 0, 19), other_slice], &[voxel(3, 5, 5)]), vec![None]);
    }

    #[test]
    fn nesting_goes_any_number_of_levels_deep() {
        // A cell, its nucleus, and a nucleolus in the nucleus.
        let loops = [square(0, 2, 0, 39), square(1, 2, 10, 29), square(2, 2, 15, 19)];
        let contested = [voxel(2, 12, 12), voxel(2, 16, 16)];
        assert_eq!(inner_classes(&loops, &contested), vec![Some(1), Some(2)]);
    }

    #[test]
    fn a_voxel_of_two_inner_loops_of_different_classes_stays_contested() {
        // Two inner loops that overlap each other inside one outer loop: neither is nested in
        // the other, so their shared voxels have no inner class.
        let loops = [square(0, 1, 0, 39), square(1, 1, 5, 14), square(2, 1, 10, 19)];
        assert_eq!(inner_classes(&loops, &[voxel(1, 12, 12), voxel(1, 6, 6)]), vec![None, Some(1)]);
    }

    #[test]
    fn shared_count_counts_common_values() {
        assert_eq!(shared_count(&[1, 3, 5, 7], &[2, 3, 4, 5, 8]), 2);
        assert_eq!(shared_count(&[], &[1]), 0);
    }
}
