//! Multi-scale voxel features (issue 9), [`super::FeatureSet::Multiscale`]: what interactive voxel
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

use super::FeatureError;
use super::eigen::symmetric_eigenvalues_lanes;
use crate::volume::{Volume, any_at_or_above};
use rayon::prelude::*;
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

    pub fn dim(self) -> usize {
        match self {
            Scales::Fine => FINE_NAMES.len(),
            Scales::Full => MULTISCALE_DIM,
        }
    }

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
/// core busy while the others wait: with at least this many blocks that tail is short.
/// Measured on 2 cores with forest-fine (session 6): engine 256 planes, blocks of 28 -> 20
/// planes, 155 -> 137 ms; the head (blocks of 32 or 16) within noise.
const MIN_BLOCKS: usize = 12;
/// Thinner blocks than this smooth more halo than core (lobster: 8 planes scored as well as
/// 14, 4 planes worse).
const MIN_BALANCED_DEPTH: usize = 8;
/// Training voxels are grouped into tiles of this many voxels per side.
const TILE: usize = 16;

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
/// few enough that the volume has at least [`MIN_BLOCKS`] of them.
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
    /// (row-major, `Scales::dim` values per voxel), [`LANES`] voxels side by side; in 256-bit
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

/// `out[i]` = mean of `input[clamp(i + d)]` for d in -radius..=radius, summed in order of d
/// (the interior a whole row at a time, so that it vectorises).
fn box_along_row(input: &[f32], out: &mut [f32], radius: usize) {
    let n = input.len();
    let scale = 1.0 / (2 * radius + 1) as f32;
    let edge = |i: usize| {
        let mut sum = 0.0;
        for d in 0..=2 * radius {
            sum += input[(i + d).saturating_sub(radius).min(n - 1)];
        }
        sum * scale
    };
    if n <= 2 * radius {
        for (i, o) in out.iter_mut().enumerate() {
            *o = edge(i);
        }
        return;
    }
    for i in (0..radius).chain(n - radius..n) {
        out[i] = edge(i);
    }
    let interior = &mut out[radius..n - radius];
    BoxSources::new(radius, |d| &input[d..n - 2 * radius + d]).mean_into(interior, scale);
}

/// The same box across rows: row y of `out` is the mean of rows clamp(y + d) of `input`, whole
/// rows at a time (vectorised along x), summed in order of d.
fn box_across_lines(input: &[f32], out: &mut [f32], nx: usize, ny: usize, radius: usize) {
    let scale = 1.0 / (2 * radius + 1) as f32;
    for (y, out_row) in out.chunks_exact_mut(nx).enumerate() {
        let sources = BoxSources::new(radius, |d| &input[(y + d).saturating_sub(radius).min(ny - 1) * nx..][..nx]);
        sources.mean_into(out_row, scale);
    }
}

/// The 2r + 1 equally long runs of values a box filter of radius r averages, in order of
/// offset.
struct BoxSources<'a> {
    runs: [&'a [f32]; BoxSources::MAX],
    count: usize,
}

impl<'a> BoxSources<'a> {
    /// Runs per box at most: radius 4, the cascade's widest.
    const MAX: usize = 9;
    /// Values summed side by side, in registers.
    const CHUNK: usize = 16;

    /// Runs `run(0)` to `run(2 * radius)`.
    fn new(radius: usize, run: impl Fn(usize) -> &'a [f32]) -> BoxSources<'a> {
        let count = (2 * radius + 1).min(Self::MAX);
        let mut runs = [&[][..]; Self::MAX];
        for (d, slot) in runs.iter_mut().enumerate().take(count) {
            *slot = run(d);
        }
        BoxSources { runs, count }
    }

    /// `out[i]` = (run 0 [i] + run 1 [i] + ... + run 2r [i]) * `scale`, added in that order
    /// (the same bits as adding whole runs into `out` one after another), a chunk at a time in
    /// registers: one pass over `out` instead of one per run; in 256-bit registers where the
    /// CPU has them (see [`crate::cpu`]).
    fn mean_into(&self, out: &mut [f32], scale: f32) {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2_fma() {
            // SAFETY: the CPU has AVX2 and FMA, checked just above.
            unsafe { self.mean_into_avx2(out, scale) };
            return;
        }
        self.mean_into_chunks(out, scale);
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn mean_into_avx2(&self, out: &mut [f32], scale: f32) {
        self.mean_into_chunks(out, scale);
    }

    #[inline(always)]
    fn mean_into_chunks(&self, out: &mut [f32], scale: f32) {
        let runs = &self.runs[..self.count];
        let n = out.len();
        let whole = n - n % Self::CHUNK;
        for start in (0..whole).step_by(Self::CHUNK) {
            let mut sum = [0f32; Self::CHUNK];
            sum.copy_from_slice(&runs[0][start..start + Self::CHUNK]);
            for run in &runs[1..] {
                for (s, &v) in sum.iter_mut().zip(&run[start..start + Self::CHUNK]) {
                    *s += v;
                }
            }
            for (o, s) in out[start..start + Self::CHUNK].iter_mut().zip(sum) {
                *o = s * scale;
            }
        }
        for (i, o) in out.iter_mut().enumerate().skip(whole) {
            let mut sum = runs[0][i];
            for run in &runs[1..] {
                sum += run[i];
            }
            *o = sum * scale;
        }
    }
}

/// Multiscale features of the voxels at `indices` (any order), row-major; parallel over 16^3
/// tiles, each one block over the bounding box of its voxels.
pub fn multiscale_features_of_voxels(
    volume: &Volume,
    scales: Scales,
    indices: &[usize],
) -> Result<Vec<f32>, FeatureError> {
    let dim = scales.dim();
    let voxel_count = volume.voxel_count();
    if let Some(&index) = indices.iter().find(|&&i| i >= voxel_count) {
        return Err(FeatureError::VoxelOutOfRange { index, voxel_count });
    }
    let [size_x, size_y, _] = volume.dims;
    let position = |index: usize| [index % size_x, (index / size_x) % size_y, index / (size_x * size_y)];
    let mut order: Vec<(usize, usize)> = indices
        .iter()
        .enumerate()
        .map(|(k, &index)| {
            let [x, y, z] = position(index);
            let tile = (z / TILE) * (size_x.div_ceil(TILE) * size_y.div_ceil(TILE))
                + (y / TILE) * size_x.div_ceil(TILE)
                + x / TILE;
            (tile, k)
        })
        .collect();
    order.sort_unstable();
    let groups: Vec<&[(usize, usize)]> = order.chunk_by(|a, b| a.0 == b.0).collect();
    // Each tile's (tile, position in `indices`) pairs and its voxels' features.
    type TileFeatures<'a> = (&'a [(usize, usize)], Vec<f32>);
    let rows: Vec<TileFeatures> = groups
        .par_iter()
        .map_init(
            || MultiscaleBlock::new(volume, scales),
            |block, &group| {
                let voxels: Vec<[usize; 3]> = group.iter().map(|&(_, k)| position(indices[k])).collect();
                let core = std::array::from_fn(|a| {
                    let low = voxels.iter().map(|v| v[a]).min().unwrap_or(0);
                    let high = voxels.iter().map(|v| v[a]).max().unwrap_or(0);
                    low..high + 1
                });
                block.compute(volume, core);
                let mut features = vec![0f32; voxels.len() * dim];
                block.features_of(&voxels, &mut features);
                (group, features)
            },
        )
        .collect();
    let mut out = vec![0f32; indices.len() * dim];
    for (group, features) in rows {
        for (&(_, k), row) in group.iter().zip(features.chunks_exact(dim)) {
            out[k * dim..(k + 1) * dim].copy_from_slice(row);
        }
    }
    Ok(out)
}

/// Whole-volume reader: keeps one block of full z planes and moves it forward when asked for
/// a plane outside it. With a foreground threshold, a block covers only the xy bounding box of
/// its planes' voxels at or above it (plus the halo), since only those are ever classified;
/// a voxel outside that box reloads the block with whole planes.
pub struct MultiscaleSlabReader<'v> {
    volume: &'v Volume,
    block: MultiscaleBlock,
    depth: usize,
    foreground_threshold: Option<f32>,
    /// The z planes loaded, and whether the block covers them whole.
    loaded: Option<(Range<usize>, bool)>,
    plane: Vec<f32>,
    /// The voxels asked for, as positions.
    voxels: Vec<[usize; 3]>,
}

impl<'v> MultiscaleSlabReader<'v> {
    pub fn new(volume: &'v Volume, scales: Scales) -> MultiscaleSlabReader<'v> {
        MultiscaleSlabReader {
            volume,
            block: MultiscaleBlock::new(volume, scales),
            depth: block_depth(volume.dims),
            foreground_threshold: None,
            loaded: None,
            plane: Vec::new(),
            voxels: Vec::new(),
        }
    }

    /// Only voxels at or above `threshold` will be asked for (see the type's doc).
    pub fn with_foreground_threshold(mut self, threshold: f32) -> Self {
        self.foreground_threshold = Some(threshold);
        self
    }

    /// Features of the voxels `selected` (indices within z plane `z`) into `out` (cleared and
    /// resized to `selected.len() x dim`). `z` and `selected` must be inside the volume (the
    /// caller checks).
    pub fn compute_selected(&mut self, z: usize, selected: &[usize], out: &mut Vec<f32>) {
        let dim = self.block.scales.dim();
        // `features_of` writes every value: no need to zero them first.
        out.resize(selected.len() * dim, 0.0);
        out.truncate(selected.len() * dim);
        if selected.is_empty() {
            return;
        }
        let [size_x, size_y, size_z] = self.volume.dims;
        self.voxels.clear();
        self.voxels.extend(PlanePositions::new(size_x).of(selected, z));
        // Blocks start on multiples of the depth, so that workers asked for neighbouring planes
        // in any order load each block once, and hold the next block's first plane too (the
        // coarse plane a slab of coarse-to-fine labelling needs beyond its own).
        let start = z - z % self.depth;
        let planes = start..(start + self.depth + 1).min(size_z);
        let inside = |core: &[Range<usize>; 3], voxels: &[[usize; 3]]| {
            voxels.iter().all(|v| core[0].contains(&v[0]) && core[1].contains(&v[1]))
        };
        let current = self.loaded.as_ref().filter(|(range, _)| range.contains(&z));
        match current {
            Some(_) if inside(self.block.core(), &self.voxels) => {}
            Some(_) => {
                self.block.compute(self.volume, [0..size_x, 0..size_y, planes.clone()]);
                self.loaded = Some((planes, true));
            }
            None => {
                let [xs, ys] = match self.foreground_threshold {
                    Some(threshold) => self.foreground_box(planes.clone(), threshold),
                    None => [0..size_x, 0..size_y],
                };
                let whole = xs.len() == size_x && ys.len() == size_y;
                self.block.compute(self.volume, [xs, ys, planes.clone()]);
                self.loaded = Some((planes.clone(), whole));
                if !inside(self.block.core(), &self.voxels) {
                    self.block.compute(self.volume, [0..size_x, 0..size_y, planes.clone()]);
                    self.loaded = Some((planes, true));
                }
            }
        }
        self.block.features_of(&self.voxels, out);
    }

    /// The x and y ranges of the voxels at or above `threshold` in z planes `planes` (a single
    /// voxel when there are none).
    fn foreground_box(&mut self, planes: Range<usize>, threshold: f32) -> [Range<usize>; 2] {
        let [size_x, size_y, _] = self.volume.dims;
        let (mut low, mut high) = ([usize::MAX; 2], [0usize; 2]);
        self.plane.resize(size_x * size_y, 0.0);
        for z in planes {
            self.volume.read_z_slice_f32(z, &mut self.plane);
            for (y, row) in self.plane.chunks_exact(size_x).enumerate() {
                // Most rows are air: a vectorised test skips them.
                if !any_at_or_above(row, threshold) {
                    continue;
                }
                let Some(first) = row.iter().position(|&v| v >= threshold) else {
                    continue;
                };
                let last = row.iter().rposition(|&v| v >= threshold).unwrap_or(first);
                low = [low[0].min(first), low[1].min(y)];
                high = [high[0].max(last), high[1].max(y)];
            }
        }
        if low[0] == usize::MAX { [0..1, 0..1] } else { [low[0]..high[0] + 1, low[1]..high[1] + 1] }
    }

    pub fn depth(&self) -> usize {
        self.depth
    }
}

/// Plane indices (`x + size_x * y`) to positions without a division per voxel: selections
/// come in ascending order, mostly a few voxels apart, so the row is tracked and divided for
/// only when an index leaves it (an integer division costs tens of cycles, as much as the
/// rest of the bookkeeping of a voxel).
struct PlanePositions {
    size_x: usize,
    row_start: usize,
    y: usize,
}

impl PlanePositions {
    fn new(size_x: usize) -> PlanePositions {
        PlanePositions { size_x, row_start: 0, y: 0 }
    }

    /// The positions of plane indices `indices` in z plane `z`, in any order.
    fn of<'a>(mut self, indices: &'a [usize], z: usize) -> impl Iterator<Item = [usize; 3]> + 'a {
        indices.iter().map(move |&index| {
            if index.wrapping_sub(self.row_start) >= self.size_x {
                self.y = index / self.size_x;
                self.row_start = self.y * self.size_x;
            }
            [index - self.row_start, self.y, z]
        })
    }
}

#[cfg(test)]
#[path = "multiscale_tests.rs"]
mod tests;
