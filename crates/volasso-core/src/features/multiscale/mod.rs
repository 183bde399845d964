//! Multi-scale voxel features, [`super::FeatureSet::Multiscale`]: what interactive voxel
//! classifiers (ilastik-style) feed a random forest, in 17 dimensions:
//! 0. intensity;
//! 1-4. the volume smoothed at scales sigma = 0.82, 1.15, 1.83 and 3.16 voxels;
//! 5-8. gradient magnitude of each smoothed volume (value units per mm);
//! 9-11. Hessian eigenvalues of the sigma = 1.15 volume, ascending (per mm^2);
//! 12-14. Hessian eigenvalues of the sigma = 3.16 volume, ascending;
//! 15. intensity minus the sigma = 1.15 volume, 16. the sigma = 1.15 minus the sigma = 3.16
//!     volume (differences of Gaussians: a thin bright sheet or tube stands out of both
//!     scales, a blurred edge of a thick structure does not).
//!
//! Smoothing is a cascade of box filters of radii 1, 1, 2, 4 voxels (each separable, x then y
//! then z); by the central limit theorem a cascade of boxes approaches a Gaussian, and the
//! variances add: r (r + 1) / 3 per box, so sigma^2 = 2/3, 4/3, 10/3, 10. Each box costs
//! 2r + 1 additions per voxel and axis, vectorised along rows. Borders clamp to the edge at
//! every stage; derivatives are central differences of the smoothed volume, one-sided at a
//! border, as in the paper's 5-D set.
//!
//! [`Scales::Fine`] (`FeatureSet::MultiscaleFine`, the default) keeps the first two scales
//! only: 9 features, a 3-voxel halo, about a third of the work.
//!
//! Everything is computed blockwise and on the fly, never as a copy of the volume: a
//! [`MultiscaleBlock`] smooths one box of the volume (the voxels asked for plus a halo of
//! [`HALO`] voxels), and features are read out of it for the voxels asked for. Whole-volume
//! passes use blocks of full z planes ([`block_depth`] of them and the next block's first,
//! chosen so that one worker's buffers stay within [`BLOCK_BUDGET_BYTES`]: about
//! 6 * depth + 78 planes of f32, and that a volume has a dozen blocks or more); training
//! voxels are grouped into 16^3 tiles and each tile's bounding box is one block. Sums run in
//! the same order in every block, so both paths give the same bits for the same voxel. Each
//! thread keeps its last block's buffers for the next pass (at most the budget per thread).
//! Memory per worker: engine 256^2 planes, depth 20: 51 MiB (full set), 26 MiB (fine set);
//! 512^2 planes fall to the minimum depth 4 and exceed the budget (about 100 MiB).
//!
//! Never: keeps a float copy of the whole volume, or knows about classes.

mod box_filter;
mod reader;

pub(super) use reader::foreground_box;
pub use reader::{MultiscaleSlabReader, multiscale_features_of_voxels};

use super::eigen::symmetric_eigenvalues_lanes;
use crate::volume::Volume;
use box_filter::{BoxSources, box_across_lines, box_along_row};
use std::ops::Range;

/// Radii of the cascaded box filters, in voxels.
pub const CASCADE_RADII: [usize; 4] = [1, 1, 2, 4];
/// Voxels a block reads beyond the voxels whose features it gives: the cascade's reach plus
/// one for the derivatives (for [`Scales::Full`]; [`Scales::Fine`] needs 3).
pub const HALO: usize = 9;
/// Features per voxel (at most; [`Scales::dim`]).
pub const MULTISCALE_DIM: usize = 17;

/// How far up the cascade a feature set goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scales {
    /// sigma 0.82 and 1.15 only (9 features: intensity, the two smoothed volumes and their
    /// gradient magnitudes, the Hessian eigenvalues at 1.15, intensity minus the 1.15 volume):
    /// the first two boxes of the cascade, a 3-voxel halo, about a third of the work.
    Fine,
    /// All four scales (the 17 features of the module doc).
    Full,
}

impl Scales {
    fn stage_count(self) -> usize {
        match self {
            Scales::Fine => 2,
            Scales::Full => 4,
        }
    }

    /// Features per voxel: 9 for [`Scales::Fine`], 17 for [`Scales::Full`].
    pub fn dim(self) -> usize {
        match self {
            Scales::Fine => FINE_NAMES.len(),
            Scales::Full => MULTISCALE_DIM,
        }
    }

    /// Short names of the features, in vector order ([`FINE_NAMES`] or [`MULTISCALE_NAMES`]).
    pub fn names(self) -> &'static [&'static str] {
        match self {
            Scales::Fine => &FINE_NAMES,
            Scales::Full => &MULTISCALE_NAMES,
        }
    }

    /// Voxels a block reads around its core.
    pub fn halo(self) -> usize {
        margin(0, self.stage_count())
    }
}

/// Names of the 9 features of [`Scales::Fine`], in vector order (`s` is the smoothing sigma in voxels).
pub const FINE_NAMES: [&str; 9] = [
    "intensity",
    "smoothed s0.8",
    "smoothed s1.2",
    "gradient s0.8",
    "gradient s1.2",
    "hessian low s1.2",
    "hessian mid s1.2",
    "hessian high s1.2",
    "intensity - s1.2",
];
/// One worker's block buffers stay below this where a plane is small enough to allow at least
/// 4 planes (about 6 * depth + 78 planes of f32 for the full set, 4 * depth + 18 for the fine).
pub const BLOCK_BUDGET_BYTES: usize = 64 << 20;
const MIN_BLOCK_DEPTH: usize = 4;
const MAX_BLOCK_DEPTH: usize = 32;
/// A whole-volume pass is one parallel task per block, and the last task to start keeps one
/// core busy while the others wait: with at least this many blocks that tail is short
/// (`docs/decisions/0016-random-forest.md`).
const MIN_BLOCKS: usize = 12;
/// Thinner blocks than this smooth more halo than core (lobster: 8 planes scored as well as
/// 14, 4 planes worse).
const MIN_BALANCED_DEPTH: usize = 8;

/// Names of the 17 features of [`Scales::Full`], in vector order (`s` is the smoothing sigma in voxels).
pub const MULTISCALE_NAMES: [&str; MULTISCALE_DIM] = [
    "intensity",
    "smoothed s0.8",
    "smoothed s1.2",
    "smoothed s1.8",
    "smoothed s3.2",
    "gradient s0.8",
    "gradient s1.2",
    "gradient s1.8",
    "gradient s3.2",
    "hessian low s1.2",
    "hessian mid s1.2",
    "hessian high s1.2",
    "hessian low s3.2",
    "hessian mid s3.2",
    "hessian high s3.2",
    "intensity - s1.2",
    "s1.2 - s3.2",
];

/// Z planes per whole-volume block for a volume of `dims`: what the memory budget allows, but
/// few enough that the volume has at least `MIN_BLOCKS` (12) of them.
pub fn block_depth(dims: [usize; 3]) -> usize {
    let plane_bytes = (dims[0] * dims[1]).max(1) * 4;
    let planes = BLOCK_BUDGET_BYTES / plane_bytes;
    let budget = (planes.saturating_sub(78) / 6).clamp(MIN_BLOCK_DEPTH, MAX_BLOCK_DEPTH);
    let balanced = (dims[2] / MIN_BLOCKS).max(MIN_BALANCED_DEPTH);
    // Even, so that a block holds whole pairs of planes: the coarse planes of coarse-to-fine
    // labelling (every second plane) then map onto blocks without straddling them.
    budget.min(balanced) & !1
}

/// Extra voxels needed around the core by stage k's output (k = 0 is the raw values): the
/// later stages' radii plus one for the derivatives.
fn margin(stage: usize, stage_count: usize) -> usize {
    1 + CASCADE_RADII[stage.min(stage_count)..stage_count].iter().sum::<usize>()
}

/// The smoothed cascade over one box of the volume. `origin` and `size` give the loaded
/// region (the core plus [`HALO`], clipped to the volume); stage k holds z planes
/// `stage_z[k]` (local) of its output, just those the core's features need.
pub struct MultiscaleBlock {
    scales: Scales,
    dims: [usize; 3],
    spacing_mm: [f32; 3],
    /// 1 / (2 spacing): the gradient's scale away from the volume's faces.
    interior_inverse_span_mm: [f32; 3],
    origin: [usize; 3],
    size: [usize; 3],
    core: [Range<usize>; 3],
    /// Stage 0 is the raw values, stages 1-4 the smoothed volumes.
    stages: [Vec<f32>; 5],
    stage_z: [Range<usize>; 5],
    row: Vec<f32>,
    xy_filtered: Vec<f32>,
}

/// The buffers of a [`MultiscaleBlock`], kept per thread between whole-volume passes:
/// allocating tens of megabytes per parallel task costs more in page faults than the
/// smoothing of a small volume.
#[derive(Default)]
struct BlockBuffers {
    stages: [Vec<f32>; 5],
    row: Vec<f32>,
    xy_filtered: Vec<f32>,
}

thread_local! {
    static SPARE_BUFFERS: std::cell::RefCell<Option<BlockBuffers>> = const { std::cell::RefCell::new(None) };
}

impl MultiscaleBlock {
    /// An empty block for `volume` at `scales`, reusing this thread's spare buffers; `compute` fills it.
    pub fn new(volume: &Volume, scales: Scales) -> MultiscaleBlock {
        let buffers = SPARE_BUFFERS.with(|spare| spare.borrow_mut().take()).unwrap_or_default();
        MultiscaleBlock {
            scales,
            dims: volume.dims,
            spacing_mm: volume.spacing_mm.map(|s| s as f32),
            interior_inverse_span_mm: volume.spacing_mm.map(|s| 1.0 / (2.0 * s as f32)),
            origin: [0; 3],
            size: [0; 3],
            core: [0..0, 0..0, 0..0],
            stages: buffers.stages,
            stage_z: Default::default(),
            row: buffers.row,
            xy_filtered: buffers.xy_filtered,
        }
    }

    /// The voxels whose features the block holds.
    pub fn core(&self) -> &[Range<usize>; 3] {
        &self.core
    }

    /// Loads and smooths the region around `core` (absolute voxel ranges inside the volume).
    pub fn compute(&mut self, volume: &Volume, core: [Range<usize>; 3]) {
        let dims = volume.dims;
        let stage_count = self.scales.stage_count();
        let halo = self.scales.halo();
        let region: [Range<usize>; 3] =
            std::array::from_fn(|a| core[a].start.saturating_sub(halo)..(core[a].end + halo).min(dims[a]));
        self.origin = region.clone().map(|r| r.start);
        self.size = region.clone().map(|r| r.len());
        let [nx, ny, nz] = self.size;
        let plane = nx * ny;
        for stage in 0..=stage_count {
            let reach = margin(stage, stage_count);
            let start = (core[2].start.saturating_sub(reach)).max(region[2].start) - self.origin[2];
            let end = (core[2].end + reach).min(region[2].end) - self.origin[2];
            self.stage_z[stage] = start..end;
        }
        self.core = core;

        // Stage 0: raw values, row by row.
        let raw_z = self.stage_z[0].clone();
        let raw = &mut self.stages[0];
        // Every value is overwritten, so buffers only grow (no clearing memset).
        raw.resize(raw_z.len() * plane, 0.0);
        for (local_z, plane_out) in raw_z.clone().zip(raw.chunks_exact_mut(plane)) {
            for (local_y, row_out) in plane_out.chunks_exact_mut(nx).enumerate() {
                let start = volume.index(self.origin[0], self.origin[1] + local_y, self.origin[2] + local_z);
                volume.read_f32(start, row_out);
            }
        }

        for stage in 1..=stage_count {
            let radius = CASCADE_RADII[stage - 1];
            let (input_z, output_z) = (self.stage_z[stage - 1].clone(), self.stage_z[stage].clone());
            let (before, after) = self.stages.split_at_mut(stage);
            let input = &before[stage - 1];
            // x then y, plane by plane, into xy_filtered (same planes as the input).
            self.xy_filtered.resize(input.len(), 0.0);
            self.row.resize(plane, 0.0);
            for (input_plane, filtered_plane) in input.chunks_exact(plane).zip(self.xy_filtered.chunks_exact_mut(plane))
            {
                for (input_row, row) in input_plane.chunks_exact(nx).zip(self.row.chunks_exact_mut(nx)) {
                    box_along_row(input_row, row, radius);
                }
                box_across_lines(&self.row, filtered_plane, nx, ny, radius);
            }
            // Then z, only for the output planes.
            let output = &mut after[0];
            output.resize(output_z.len() * plane, 0.0);
            let scale = 1.0 / (2 * radius + 1) as f32;
            let last = nz - 1;
            for (local_z, output_plane) in output_z.clone().zip(output.chunks_exact_mut(plane)) {
                let sources = BoxSources::new(radius, |d| {
                    let source_z = (local_z + d).saturating_sub(radius).min(last).clamp(input_z.start, input_z.end - 1);
                    &self.xy_filtered[(source_z - input_z.start) * plane..][..plane]
                });
                sources.mean_into(output_plane, scale);
            }
        }
    }

    /// Value of stage `stage` at local (x, y, z), each clamped into the region.
    #[inline(always)]
    fn at(&self, stage: usize, x: isize, y: isize, z: isize) -> f32 {
        let [nx, ny, _] = self.size;
        let x = x.clamp(0, nx as isize - 1) as usize;
        let y = y.clamp(0, ny as isize - 1) as usize;
        let z_range = &self.stage_z[stage];
        let z = (z.max(0) as usize).clamp(z_range.start, z_range.end - 1);
        self.stages[stage][((z - z_range.start) * ny + y) * nx + x]
    }

    /// The features of the absolute voxels `voxels`, which must lie in the core, into `out`
    /// (row-major, `Scales::dim` values per voxel), `LANES` voxels side by side; in 256-bit
    /// registers where the CPU has them (the same bits, see [`crate::cpu`]).
    pub fn features_of(&self, voxels: &[[usize; 3]], out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2_fma() {
            // SAFETY: the CPU has AVX2 and FMA, checked just above.
            unsafe { self.features_of_avx2(voxels, out) };
            return;
        }
        self.features_of_lanes(voxels, out);
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn features_of_avx2(&self, voxels: &[[usize; 3]], out: &mut [f32]) {
        self.features_of_lanes(voxels, out);
    }

    /// The body of [`Self::features_of`], inlined (with everything it calls) into each variant.
    #[inline(always)]
    fn features_of_lanes(&self, voxels: &[[usize; 3]], out: &mut [f32]) {
        let dim = self.scales.dim();
        let stage_count = self.scales.stage_count();
        let mut neighbours = Neighbours::default();
        for (group, group_out) in voxels.chunks(LANES).zip(out.chunks_mut(LANES * dim)) {
            // A short group repeats its last voxel; those lanes are not written out.
            let voxel = |lane: usize| group[lane.min(group.len() - 1)];
            let locals: [[isize; 3]; LANES] =
                std::array::from_fn(|lane| std::array::from_fn(|a| (voxel(lane)[a] - self.origin[a]) as isize));
            let inverse_span: [[f32; LANES]; 3] =
                std::array::from_fn(|a| std::array::from_fn(|lane| self.inverse_span_mm(a, voxel(lane)[a])));
            // Feature-major: features[k][lane].
            let mut features = [[0f32; LANES]; MULTISCALE_DIM];
            for (value, &[x, y, z]) in features[0].iter_mut().zip(&locals) {
                *value = self.at(0, x, y, z);
            }
            for stage in 1..=stage_count {
                let hessian = stage % 2 == 0;
                self.gather(stage, &locals, hessian, &mut neighbours);
                for lane in 0..LANES {
                    let difference =
                        |a: usize| (neighbours.plus[a][lane] - neighbours.minus[a][lane]) * inverse_span[a][lane];
                    let (gx, gy, gz) = (difference(0), difference(1), difference(2));
                    features[stage][lane] = neighbours.centre[lane];
                    features[stage_count + stage][lane] = (gx * gx + gy * gy + gz * gz).sqrt();
                }
                if hessian {
                    // The eigenvalues at stage 2 (and 4) follow the gradients.
                    let first = 2 * stage_count + 1 + 3 * (stage / 2 - 1);
                    let eigenvalues = symmetric_eigenvalues_lanes(&self.hessians(&neighbours));
                    features[first..first + 3].copy_from_slice(&eigenvalues);
                }
            }
            // Differences of Gaussians.
            let differences: &[(usize, usize, usize)] = match self.scales {
                Scales::Fine => &[(8, 0, 2)],
                Scales::Full => &[(15, 0, 2), (16, 2, 4)],
            };
            for &(k, from, minus) in differences {
                features[k] = std::array::from_fn(|lane| features[from][lane] - features[minus][lane]);
            }
            for (lane, row) in group_out.chunks_exact_mut(dim).enumerate() {
                for (value, feature) in row.iter_mut().zip(&features) {
                    *value = feature[lane];
                }
            }
        }
    }

    /// 1 / (mm spanned by the clamped central difference) at coordinate `p` along `axis`, as
    /// in the paper's set; 0 on an axis one voxel long.
    #[inline(always)]
    fn inverse_span_mm(&self, axis: usize, p: usize) -> f32 {
        let span = (p + 1).min(self.dims[axis] - 1) - p.saturating_sub(1);
        if span == 2 {
            self.interior_inverse_span_mm[axis]
        } else if span == 0 {
            0.0
        } else {
            1.0 / (span as f32 * self.spacing_mm[axis])
        }
    }

    /// The values of stage `stage` around each of `locals` (local positions, clamped into the
    /// region) into `neighbours`; the diagonal ones only with `diagonals`. Away from the
    /// region's faces (nearly every voxel) they are read with fixed strides, without clamping
    /// each one.
    #[inline(always)]
    fn gather(&self, stage: usize, locals: &[[isize; 3]; LANES], diagonals: bool, neighbours: &mut Neighbours) {
        let [nx, ny, _] = self.size;
        let z_range = &self.stage_z[stage];
        let values = &self.stages[stage];
        for (lane, &[x, y, z]) in locals.iter().enumerate() {
            let interior = x >= 1
                && y >= 1
                && z >= 1
                && (x as usize) + 1 < nx
                && (y as usize) + 1 < ny
                && (z as usize) > z_range.start
                && (z as usize) + 1 < z_range.end;
            if interior {
                let centre = ((z as usize - z_range.start) * ny + y as usize) * nx + x as usize;
                let stride = [1, nx as isize, (nx * ny) as isize];
                let value = |d: [isize; 3]| {
                    values[(centre as isize + d[0] * stride[0] + d[1] * stride[1] + d[2] * stride[2]) as usize]
                };
                neighbours.fill_lane(lane, diagonals, value);
            } else {
                neighbours.fill_lane(lane, diagonals, |d: [isize; 3]| self.at(stage, x + d[0], y + d[1], z + d[2]));
            }
        }
    }

    /// The Hessians, from second differences in value units per mm^2, of the lanes of
    /// `neighbours`, entry by entry ([xx, yy, zz, xy, xz, yz]; see
    /// [`symmetric_eigenvalues_lanes`]).
    #[inline(always)]
    fn hessians(&self, neighbours: &Neighbours) -> [[f64; LANES]; 6] {
        let spacing = self.spacing_mm.map(|s| s as f64);
        let mut entries = [[0f64; LANES]; 6];
        // Entry by entry over the lanes (not lane by lane), so that the divisions run in vector
        // instructions.
        for a in 0..3 {
            let scale = spacing[a] * spacing[a];
            for (lane, entry) in entries[a].iter_mut().enumerate() {
                let centre = neighbours.centre[lane] as f64;
                let (plus, minus) = (neighbours.plus[a][lane] as f64, neighbours.minus[a][lane] as f64);
                *entry = (plus - 2.0 * centre + minus) / scale;
            }
        }
        for (pair, &(a, b)) in AXIS_PAIRS.iter().enumerate() {
            let scale = 4.0 * spacing[a] * spacing[b];
            let [plus_plus, plus_minus, minus_plus, minus_minus] = &neighbours.diagonal[pair];
            for (lane, entry) in entries[3 + pair].iter_mut().enumerate() {
                let corner = |values: &[f32; LANES]| values[lane] as f64;
                *entry = (corner(plus_plus) - corner(plus_minus) - corner(minus_plus) + corner(minus_minus)) / scale;
            }
        }
        entries
    }
}

/// Voxels whose features [`MultiscaleBlock::features_of`] computes side by side: independent
/// voxels overlap their long chains of dependent arithmetic, and the eigenvalues run in vector
/// instructions.
const LANES: usize = 8;

/// The axis pairs of the Hessian's mixed derivatives: xy, xz, yz.
const AXIS_PAIRS: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];

/// Values of one stage around a group of voxels, lane by lane.
#[derive(Default)]
struct Neighbours {
    centre: [f32; LANES],
    /// The neighbours one voxel below and above along each axis.
    minus: [[f32; LANES]; 3],
    plus: [[f32; LANES]; 3],
    /// For each of [`AXIS_PAIRS`] (a, b): the neighbours at (+a, +b), (+a, -b), (-a, +b), (-a, -b).
    diagonal: [[[f32; LANES]; 4]; 3],
}

impl Neighbours {
    /// Fills lane `lane` from `value`, the value at an offset from the lane's voxel.
    #[inline(always)]
    fn fill_lane(&mut self, lane: usize, diagonals: bool, value: impl Fn([isize; 3]) -> f32) {
        let step =
            |axis: usize, sign: isize| -> [isize; 3] { std::array::from_fn(|a| if a == axis { sign } else { 0 }) };
        self.centre[lane] = value([0; 3]);
        for axis in 0..3 {
            self.minus[axis][lane] = value(step(axis, -1));
            self.plus[axis][lane] = value(step(axis, 1));
        }
        if diagonals {
            for (pair, &(a, b)) in AXIS_PAIRS.iter().enumerate() {
                for (corner, (sign_a, sign_b)) in [(1, 1), (1, -1), (-1, 1), (-1, -1)].into_iter().enumerate() {
                    let offset = std::array::from_fn(|axis| step(a, sign_a)[axis] + step(b, sign_b)[axis]);
                    self.diagonal[pair][corner][lane] = value(offset);
                }
            }
        }
    }
}

impl Drop for MultiscaleBlock {
    fn drop(&mut self) {
        let buffers = BlockBuffers {
            stages: std::mem::take(&mut self.stages),
            row: std::mem::take(&mut self.row),
            xy_filtered: std::mem::take(&mut self.xy_filtered),
        };
        // One spare set per thread; a thread's later block reuses it.
        SPARE_BUFFERS.with(|spare| *spare.borrow_mut() = Some(buffers));
    }
}

#[cfg(test)]
mod tests;
