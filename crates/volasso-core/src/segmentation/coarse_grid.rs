//! The coarse grid of coarse-to-fine labelling and the per-voxel test: take the coarse
//! neighbours' label, or be evaluated (`docs/decisions/0014-coarse-to-fine.md`).

use crate::volume::any_at_or_above;
use std::ops::{Range, RangeInclusive};

/// The coarse coordinates next to fine `p` on an axis `coarse_size` long: an odd `p` lies
/// between two, an even one (or an odd one at the far border) on one, held twice.
#[inline]
fn coarse_neighbours(p: usize, coarse_size: usize) -> [usize; 2] {
    [p / 2, (p / 2 + p % 2).min(coarse_size - 1)]
}

/// The distinct coordinates of a [`coarse_neighbours`] pair.
fn distinct(pair: &[usize; 2]) -> &[usize] {
    if pair[0] == pair[1] { &pair[..1] } else { pair }
}

/// Labels and intensities of every second voxel along each axis, for all coarse planes or a run.
pub(super) struct CoarseGrid {
    /// Coarse voxels per row and column, and the coarse planes held.
    pub dims: [usize; 3],
    /// The coarse z of the first plane held.
    pub first_plane: usize,
    /// Coarse z planes of the whole volume (where neighbours clamp).
    pub volume_planes: usize,
    pub labels: Vec<u8>,
    pub values: Vec<f32>,
}

impl CoarseGrid {
    /// The grid of a whole volume of `fine` dimensions.
    pub fn new(fine: [usize; 3]) -> CoarseGrid {
        let mut grid =
            CoarseGrid { dims: [0; 3], first_plane: 0, volume_planes: 0, labels: Vec::new(), values: Vec::new() };
        grid.hold(fine, 0..fine[2].div_ceil(2));
        grid
    }

    /// Makes the grid hold coarse planes `planes` of a volume of `fine` dimensions, labels zeroed.
    pub fn hold(&mut self, fine: [usize; 3], planes: Range<usize>) {
        let [coarse_x, coarse_y, volume_planes] = fine.map(|d| d.div_ceil(2));
        self.dims = [coarse_x, coarse_y, planes.len()];
        self.first_plane = planes.start;
        self.volume_planes = volume_planes;
        let count = coarse_x * coarse_y * planes.len();
        self.labels.clear();
        self.labels.resize(count, 0);
        self.values.resize(count, 0.0);
    }

    /// Coarse voxels per plane.
    pub fn plane_len(&self) -> usize {
        self.dims[0] * self.dims[1]
    }
}

/// The coarse rows next to one fine row, per coarse column: their foreground voxels' classes (a bit
/// each) and intensity range, so that each fine voxel's test is two lookups.
#[derive(Default)]
pub(super) struct RowNeighbours {
    classes: Vec<u32>,
    low: Vec<f32>,
    high: Vec<f32>,
    /// Per fine column: its coarse neighbours' one class (0: none or several) and widened range.
    single_class: Vec<u8>,
    fine_low: Vec<f32>,
    fine_high: Vec<f32>,
}

impl RowNeighbours {
    /// Classes a `u32` bit set holds (class k is bit k - 1); with more, labelling is exact.
    pub const MAX_CLASSES: usize = 31;

    /// Summarises the coarse rows next to fine row `y` of plane `z` at coarse `columns`, for
    /// fine columns `2 * start..=2 * end` only (others stay stale), ranges widened by `tolerance`.
    pub fn summarise(&mut self, grid: &CoarseGrid, y: usize, z: usize, columns: RangeInclusive<usize>, tolerance: f32) {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2_fma() {
            // SAFETY: the CPU has AVX2 and FMA, checked just above.
            unsafe { self.summarise_avx2(grid, y, z, columns, tolerance) };
            return;
        }
        self.summarise_lanes(grid, y, z, columns, tolerance);
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn summarise_avx2(
        &mut self,
        grid: &CoarseGrid,
        y: usize,
        z: usize,
        columns: RangeInclusive<usize>,
        tolerance: f32,
    ) {
        self.summarise_lanes(grid, y, z, columns, tolerance);
    }

    /// The body of [`Self::summarise`], inlined into each variant (see [`crate::cpu`]).
    #[inline(always)]
    fn summarise_lanes(
        &mut self,
        grid: &CoarseGrid,
        y: usize,
        z: usize,
        columns: RangeInclusive<usize>,
        tolerance: f32,
    ) {
        let [coarse_x, coarse_y, _] = grid.dims;
        self.classes.resize(coarse_x, 0);
        self.low.resize(coarse_x, f32::INFINITY);
        self.high.resize(coarse_x, f32::NEG_INFINITY);
        let columns = *columns.start()..(*columns.end() + 1).min(coarse_x);
        let classes = &mut self.classes[columns.clone()];
        let low = &mut self.low[columns.clone()];
        let high = &mut self.high[columns.clone()];
        classes.fill(0);
        low.fill(f32::INFINITY);
        high.fill(f32::NEG_INFINITY);
        let (ys, zs) = (coarse_neighbours(y, coarse_y), coarse_neighbours(z, grid.volume_planes));
        for &cz in distinct(&zs) {
            for &cy in distinct(&ys) {
                // The caller holds the planes next to z (see `CoarseGrid::hold`).
                let start = coarse_x * (cy + coarse_y * (cz - grid.first_plane));
                let row_labels = &grid.labels[start + columns.start..start + columns.end];
                let row_values = &grid.values[start + columns.start..start + columns.end];
                let summary = classes.iter_mut().zip(low.iter_mut()).zip(high.iter_mut());
                for (((classes, low), high), (&label, &value)) in summary.zip(row_labels.iter().zip(row_values)) {
                    // Background, whose value may be stale, sets no bit and no range.
                    *classes |= 1u32.wrapping_shl(u32::from(label)) >> 1;
                    let foreground = label != 0;
                    let (lower, higher) = if foreground { (value, value) } else { (f32::INFINITY, f32::NEG_INFINITY) };
                    *low = if lower < *low { lower } else { *low };
                    *high = if higher > *high { higher } else { *high };
                }
            }
        }
        self.spread_to_fine_columns(columns, tolerance);
    }

    /// The fine columns' summaries from coarse `columns`: 2c lies on c, 2c + 1 between c and
    /// c + 1 ([`coarse_neighbours`]), so [`Self::label_row`] reads one entry per voxel.
    #[inline(always)]
    fn spread_to_fine_columns(&mut self, columns: Range<usize>, tolerance: f32) {
        let fine_len = 2 * self.classes.len();
        self.single_class.resize(fine_len, 0);
        self.fine_low.resize(fine_len, 0.0);
        self.fine_high.resize(fine_len, 0.0);
        let Some(last) = columns.end.checked_sub(1) else {
            return;
        };
        let RowNeighbours { classes, low, high, single_class: single, fine_low, fine_high } = self;
        // Each column with its right neighbour (windows and chunks vectorise), then the last.
        let pairs = columns.start..last + 1;
        let fine = 2 * columns.start..2 * last;
        let coarse = classes[pairs.clone()].windows(2).zip(low[pairs.clone()].windows(2)).zip(high[pairs].windows(2));
        let fine_columns = single[fine.clone()]
            .chunks_exact_mut(2)
            .zip(fine_low[fine.clone()].chunks_exact_mut(2))
            .zip(fine_high[fine].chunks_exact_mut(2));
        for (((single, fine_low), fine_high), ((classes, low), high)) in fine_columns.zip(coarse) {
            let coarse =
                FineSpread { classes: [classes[0], classes[1]], low: [low[0], low[1]], high: [high[0], high[1]] };
            coarse.write(single, fine_low, fine_high, tolerance);
        }
        let fine = 2 * last..2 * last + 2;
        let coarse = FineSpread { classes: [classes[last]; 2], low: [low[last]; 2], high: [high[last]; 2] };
        coarse.write(&mut single[fine.clone()], &mut fine_low[fine.clone()], &mut fine_high[fine], tolerance);
    }

    /// Labels each foreground voxel of `row` whose foreground coarse neighbours agree on one class
    /// and hold its intensity; writes the others' plane indices to the front of `selected` and
    /// returns (written, foreground). Background neighbours do not veto.
    pub fn label_row(&self, row: Row, threshold: f32, selected: &mut [usize]) -> (usize, usize) {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2_fma() {
            // SAFETY: the CPU has AVX2 and FMA, checked just above.
            return unsafe { self.label_row_avx2(row, threshold, selected) };
        }
        self.label_row_lanes(row, threshold, selected)
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn label_row_avx2(&self, row: Row, threshold: f32, selected: &mut [usize]) -> (usize, usize) {
        self.label_row_lanes(row, threshold, selected)
    }

    /// The body of [`Self::label_row`], inlined into each variant.
    #[inline(always)]
    fn label_row_lanes(&self, row: Row, threshold: f32, selected: &mut [usize]) -> (usize, usize) {
        let (first, first_index) = (row.first, row.first_index);
        let (mut count, mut foreground_count) = (0, 0);
        for (offset, values, labels) in row.chunks_with_foreground(threshold) {
            let x = first + offset;
            let summaries = self.single_class[x..]
                .iter()
                .zip(&self.fine_low[x..])
                .zip(&self.fine_high[x..])
                .map(|((&single, &low), &high)| (single, low, high));
            for ((&value, label), (single, low, high)) in values.iter().zip(labels.iter_mut()).zip(summaries) {
                // NaN is never above the threshold: it is background.
                let foreground = value >= threshold;
                let inherits = (single != 0) & (value >= low) & (value <= high);
                *label = if foreground & inherits { single } else { 0 };
            }
            // A foreground voxel without a label (labels start at 1) is evaluated.
            for (k, (&value, &label)) in values.iter().zip(labels.iter()).enumerate() {
                let foreground = value >= threshold;
                selected[count] = first_index + offset + k;
                count += usize::from(foreground & (label == 0));
                foreground_count += usize::from(foreground);
            }
        }
        (count, foreground_count)
    }
}

/// A coarse column and its right neighbour ([`RowNeighbours::spread_to_fine_columns`]).
struct FineSpread {
    classes: [u32; 2],
    low: [f32; 2],
    high: [f32; 2],
}

impl FineSpread {
    /// The summaries of the fine column on the coarse column and of the one after it.
    #[inline(always)]
    fn write(&self, single: &mut [u8], fine_low: &mut [f32], fine_high: &mut [f32], tolerance: f32) {
        let FineSpread { classes: [classes, right_classes], low: [low, right_low], high: [high, right_high] } = *self;
        single[0] = single_class(classes);
        fine_low[0] = low - tolerance;
        fine_high[0] = high + tolerance;
        single[1] = single_class(classes | right_classes);
        // Plain comparisons, not `f32::min`: no value here is NaN, and NaN rules cost blends.
        fine_low[1] = if right_low < low { right_low } else { low } - tolerance;
        fine_high[1] = if right_high > high { right_high } else { high } + tolerance;
    }
}

/// The class whose bit is the only one set in `classes`, or 0 for none or several.
#[inline(always)]
fn single_class(classes: u32) -> u8 {
    // The bit's position is the f32 exponent (exact below 2^31): unlike a bit scan, it vectorises.
    let position = (((classes & 0x7fff_ffff) as i32 as f32).to_bits() >> 23).wrapping_sub(126);
    let single = (classes != 0) & (classes & classes.wrapping_sub(1) == 0) & (classes >> 31 == 0);
    if single { position as u8 } else { 0 }
}

/// A span of one fine row: values and labels from column `first` (plane index `first_index`).
pub(super) struct Row<'a> {
    pub first: usize,
    pub first_index: usize,
    pub values: &'a [f32],
    pub labels: &'a mut [u8],
}

impl<'a> Row<'a> {
    /// Voxels per chunk that [`Row::chunks_with_foreground`] tests at once.
    const CHUNK: usize = 32;

    /// The row's chunks that hold a foreground voxel, with their offsets (air skipped per chunk).
    #[inline(always)]
    fn chunks_with_foreground(self, threshold: f32) -> impl Iterator<Item = (usize, &'a [f32], &'a mut [u8])> {
        self.values
            .chunks(Self::CHUNK)
            .zip(self.labels.chunks_mut(Self::CHUNK))
            .enumerate()
            .filter(move |(_, (values, _))| any_at_or_above(values, threshold))
            .map(|(chunk, (values, labels))| (chunk * Self::CHUNK, values, labels))
    }

    /// Writes each foreground voxel's plane index to `selected`'s front; returns the count twice.
    pub fn select_foreground(self, threshold: f32, selected: &mut [usize]) -> (usize, usize) {
        let first_index = self.first_index;
        let mut count = 0;
        for (offset, values, _) in self.chunks_with_foreground(threshold) {
            for (k, &value) in values.iter().enumerate() {
                selected[count] = first_index + offset + k;
                count += usize::from(value >= threshold);
            }
        }
        (count, count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    impl RowNeighbours {
        /// The label fine voxel `x` of value `value` inherits, or `None` when it is evaluated.
        fn inherited_label(&self, x: usize, value: f32) -> Option<u8> {
            let (mut values, mut labels, mut selected) = ([value], [0u8], [usize::MAX]);
            let row = Row { first: x, first_index: x, values: &mut values, labels: &mut labels };
            match self.label_row(row, f32::NEG_INFINITY, &mut selected) {
                (0, 1) => Some(labels[0]),
                (1, 1) if selected[0] == x => None,
                other => panic!("unexpected outcome {other:?}"),
            }
        }
    }

    /// A 2 x 1 x 1 coarse grid (fine 4 x 1 x 1, or 3 x 1 x 1 for a far border) with the given
    /// labels and values, summarised for fine row 0 of plane 0 with `tolerance`.
    fn summary(labels: [u8; 2], values: [f32; 2], tolerance: f32) -> RowNeighbours {
        let mut grid = CoarseGrid::new([3, 1, 1]);
        grid.labels.copy_from_slice(&labels);
        grid.values.copy_from_slice(&values);
        let mut row = RowNeighbours::default();
        row.summarise(&grid, 0, 0, 0..=1, tolerance);
        row
    }

    #[test]
    fn single_class_is_the_one_bit_set_or_zero() {
        for bit in 0..32 {
            let expected = if bit < 31 { bit as u8 + 1 } else { 0 };
            assert_eq!(single_class(1 << bit), expected, "bit {bit}");
            assert_eq!(single_class((1 << bit) | 1), u8::from(bit == 0), "bits {bit} and 0");
        }
        assert_eq!(single_class(0), 0);
        assert_eq!(single_class(u32::MAX), 0);
    }

    #[test]
    fn a_fine_voxel_between_agreeing_neighbours_inherits_their_label() {
        let row = summary([2, 2], [10.0, 20.0], 0.0);
        assert_eq!(row.inherited_label(0, 10.0), Some(2));
        assert_eq!(row.inherited_label(1, 15.0), Some(2));
        let row = summary([2, 2], [10.0, 20.0], 1.0);
        assert_eq!(row.inherited_label(2, 20.5), Some(2), "within the tolerance");
    }

    #[test]
    fn disagreement_or_an_intensity_outside_the_range_means_evaluate() {
        let row = summary([1, 2], [10.0, 20.0], 0.0);
        assert_eq!(row.inherited_label(1, 15.0), None, "neighbours disagree");
        assert_eq!(row.inherited_label(0, 10.0), Some(1), "an even voxel sees one neighbour");
        let row = summary([3, 3], [10.0, 20.0], 1.0);
        assert_eq!(row.inherited_label(1, 25.0), None, "brighter than both");
        assert_eq!(row.inherited_label(1, 5.0), None, "darker than both");
    }

    #[test]
    fn background_neighbours_neither_vote_nor_veto() {
        let row = summary([0, 4], [0.0, 20.0], 0.0);
        assert_eq!(row.inherited_label(1, 20.0), Some(4));
        assert_eq!(row.inherited_label(0, 20.0), None, "no foreground neighbour");
        let row = summary([0, 0], [0.0, 0.0], 10.0);
        assert_eq!(row.inherited_label(1, 0.0), None);
    }

    #[test]
    fn the_highest_class_a_bit_set_holds_is_inherited() {
        let class = RowNeighbours::MAX_CLASSES as u8;
        let row = summary([class, class], [1.0, 1.0], 0.0);
        assert_eq!(row.inherited_label(1, 1.0), Some(class));
    }

    #[test]
    fn rows_are_summarised_per_plane_and_row() {
        // Coarse 1 x 2 x 2: fine row 1 of plane 1 sits between all four coarse voxels.
        let mut grid = CoarseGrid::new([1, 3, 3]);
        grid.labels.copy_from_slice(&[1, 1, 1, 2]);
        grid.values.fill(5.0);
        let mut row = RowNeighbours::default();
        row.summarise(&grid, 0, 0, 0..=0, 0.0);
        assert_eq!(row.inherited_label(0, 5.0), Some(1));
        row.summarise(&grid, 1, 1, 0..=0, 0.0);
        assert_eq!(row.inherited_label(0, 5.0), None);
        row.summarise(&grid, 2, 0, 0..=0, 0.0);
        assert_eq!(row.inherited_label(0, 5.0), Some(1), "the far border has one coarse row");
    }

    #[test]
    fn exact_rows_select_every_foreground_voxel_and_no_nan() {
        let values = [5.0, 1.0, f32::NAN, 7.0, 3.0];
        let mut labels = [9u8; 5];
        let mut selected = [0usize; 5];
        let row = Row { first: 2, first_index: 102, values: &values, labels: &mut labels };
        assert_eq!(row.select_foreground(3.0, &mut selected), (3, 3));
        assert_eq!(&selected[..3], &[102, 105, 106]);
    }

    #[test]
    fn the_avx2_variants_decide_as_the_portable_ones() {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2_fma() {
            let mut rng = crate::rng::SplitMix64::new(5);
            let mut grid = CoarseGrid::new([77, 6, 5]);
            grid.labels = (0..grid.labels.len()).map(|_| rng.below(4) as u8).collect();
            grid.values = (0..grid.values.len()).map(|_| rng.next_f64() as f32).collect();
            let values: Vec<f32> = (0..77).map(|_| rng.next_f64() as f32).collect();
            for (y, z) in [(0, 0), (1, 1), (4, 3), (5, 4)] {
                let (mut wide, mut portable) = (RowNeighbours::default(), RowNeighbours::default());
                // SAFETY: the CPU has AVX2 and FMA, checked above.
                unsafe { wide.summarise_avx2(&grid, y, z, 3..=36, 0.05) };
                portable.summarise_lanes(&grid, y, z, 3..=36, 0.05);
                let outcome = |neighbours: &RowNeighbours, avx2: bool| {
                    let (mut labels, mut selected) = ([0u8; 66], [0usize; 66]);
                    let row = Row { first: 6, first_index: 106, values: &values[6..72], labels: &mut labels };
                    let counts = if avx2 {
                        // SAFETY: as above.
                        unsafe { neighbours.label_row_avx2(row, 0.2, &mut selected) }
                    } else {
                        neighbours.label_row_lanes(row, 0.2, &mut selected)
                    };
                    (counts, labels, selected[..counts.0].to_vec())
                };
                assert_eq!(outcome(&wide, true), outcome(&portable, false), "row {y}, plane {z}");
            }
        }
    }
}
