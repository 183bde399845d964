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
//! passes use blocks of full z planes ([`block_depth`] of them, chosen so that one worker's
//! buffers stay within [`BLOCK_BUDGET_BYTES`]: about 6 * depth + 78 planes of f32); training
//! voxels are grouped into 16^3 tiles and each tile's bounding box is one block. Sums run in
//! the same order in every block, so both paths give the same bits for the same voxel. Each
//! thread keeps its last block's buffers for the next pass (at most the budget per thread).
//! Memory per worker: engine 256^2 planes, depth 28: 62 MiB (full set), 33 MiB (fine set);
//! 512^2 planes fall to the minimum depth 4 and exceed the budget (about 100 MiB).
//!
//! Never: keeps a float copy of the whole volume, or knows about classes.

use super::FeatureError;
use crate::volume::Volume;
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

/// Z planes per whole-volume block for a volume of `dims`.
pub fn block_depth(dims: [usize; 3]) -> usize {
    let plane_bytes = (dims[0] * dims[1]).max(1) * 4;
    let planes = BLOCK_BUDGET_BYTES / plane_bytes;
    // Even, so that a block holds whole pairs of planes: the coarse pass of coarse-to-fine
    // labelling (every second plane) then maps onto blocks without straddling them.
    (planes.saturating_sub(78) / 6).clamp(MIN_BLOCK_DEPTH, MAX_BLOCK_DEPTH) & !1
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
                for d in 0..=2 * radius {
                    let source_z = (local_z + d).saturating_sub(radius).min(last).clamp(input_z.start, input_z.end - 1);
                    let source = &self.xy_filtered[(source_z - input_z.start) * plane..][..plane];
                    if d == 0 {
                        output_plane.copy_from_slice(source);
                    } else {
                        for (o, &s) in output_plane.iter_mut().zip(source) {
                            *o += s;
                        }
                    }
                }
                output_plane.iter_mut().for_each(|o| *o *= scale);
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

    /// The 3 x 3 x 3 values of stage `stage` around local `p` (clamped into the region), x
    /// fastest: index (dz + 1) * 9 + (dy + 1) * 3 + (dx + 1). Away from the region's faces
    /// (nearly every voxel) they are read with fixed strides, without clamping each one.
    #[inline(always)]
    fn cube(&self, stage: usize, p: [isize; 3]) -> [f32; 27] {
        let [nx, ny, _] = self.size;
        let z_range = &self.stage_z[stage];
        let [x, y, z] = p;
        let interior = x >= 1
            && y >= 1
            && z >= 1
            && (x as usize) + 1 < nx
            && (y as usize) + 1 < ny
            && (z as usize) > z_range.start
            && (z as usize) + 1 < z_range.end;
        let mut cube = [0f32; 27];
        if interior {
            let centre = ((z as usize - z_range.start) * ny + y as usize) * nx + x as usize;
            let (row, plane) = (nx, nx * ny);
            let values = &self.stages[stage][centre - plane - row - 1..=centre + plane + row + 1];
            for (k, line) in cube.chunks_exact_mut(3).enumerate() {
                let start = (k / 3) * plane + (k % 3) * row;
                line.copy_from_slice(&values[start..start + 3]);
            }
        } else {
            for (k, value) in cube.iter_mut().enumerate() {
                let (dx, dy, dz) = ((k % 3) as isize - 1, ((k / 3) % 3) as isize - 1, (k / 9) as isize - 1);
                *value = self.at(stage, x + dx, y + dy, z + dz);
            }
        }
        cube
    }

    /// The features of absolute voxel (x, y, z), which must lie in the core, into `out`
    /// (`Scales::dim` values).
    pub fn features_at(&self, voxel: [usize; 3], out: &mut [f32]) {
        let local = std::array::from_fn::<isize, 3, _>(|a| (voxel[a] - self.origin[a]) as isize);
        // 1 / (mm spanned by the clamped central difference) per axis, as in the paper's set.
        let inverse_span: [f32; 3] = std::array::from_fn(|a| {
            let p = voxel[a];
            let span = (p + 1).min(self.dims[a] - 1) - p.saturating_sub(1);
            if span == 0 { 0.0 } else { 1.0 / (span as f32 * self.spacing_mm[a]) }
        });
        let stage_count = self.scales.stage_count();
        out[0] = self.at(0, local[0], local[1], local[2]);
        let mut hessians = [[0f32; 3]; 2];
        for stage in 1..=stage_count {
            let cube = self.cube(stage, local);
            let centre = cube[CUBE_CENTRE];
            let difference =
                |a: usize| (cube[CUBE_CENTRE + CUBE_STRIDE[a]] - cube[CUBE_CENTRE - CUBE_STRIDE[a]]) * inverse_span[a];
            let (gx, gy, gz) = (difference(0), difference(1), difference(2));
            out[stage] = centre;
            out[stage_count + stage] = (gx * gx + gy * gy + gz * gz).sqrt();
            if stage % 2 == 0 {
                hessians[stage / 2 - 1] = self.hessian_eigenvalues(&cube);
            }
        }
        match self.scales {
            Scales::Fine => {
                out[5..8].copy_from_slice(&hessians[0]);
                out[8] = out[0] - out[2];
            }
            Scales::Full => {
                out[9..12].copy_from_slice(&hessians[0]);
                out[12..15].copy_from_slice(&hessians[1]);
                out[15] = out[0] - out[2];
                out[16] = out[2] - out[4];
            }
        }
    }

    /// Eigenvalues (ascending) of the Hessian at the centre of `cube` (see [`Self::cube`]),
    /// from second differences, in value units per mm^2.
    fn hessian_eigenvalues(&self, cube: &[f32; 27]) -> [f32; 3] {
        let value = |offset: isize| cube[(CUBE_CENTRE as isize + offset) as usize] as f64;
        let stride = CUBE_STRIDE.map(|s| s as isize);
        let centre = value(0);
        let spacing = self.spacing_mm.map(|s| s as f64);
        let second = |a: usize| (value(stride[a]) - 2.0 * centre + value(-stride[a])) / (spacing[a] * spacing[a]);
        let mixed = |a: usize, b: usize| {
            let corner = |sa: isize, sb: isize| value(sa * stride[a] + sb * stride[b]);
            (corner(1, 1) - corner(1, -1) - corner(-1, 1) + corner(-1, -1)) / (4.0 * spacing[a] * spacing[b])
        };
        symmetric_eigenvalues([second(0), second(1), second(2), mixed(0, 1), mixed(0, 2), mixed(1, 2)])
    }
}

/// The centre of a [`MultiscaleBlock::cube`] and the index steps along x, y and z.
const CUBE_CENTRE: usize = 13;
const CUBE_STRIDE: [usize; 3] = [1, 3, 9];

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

/// Eigenvalues, ascending, of the symmetric 3x3 matrix [[a, d, e], [d, b, f], [e, f, c]] given
/// as [a, b, c, d, e, f] (the trigonometric closed form).
pub fn symmetric_eigenvalues([a, b, c, d, e, f]: [f64; 6]) -> [f32; 3] {
    let off = d * d + e * e + f * f;
    if off <= 1e-30 * (a * a + b * b + c * c).max(1e-300) {
        let mut values = [a as f32, b as f32, c as f32];
        values.sort_by(f32::total_cmp);
        return values;
    }
    let q = (a + b + c) / 3.0;
    let p2 = (a - q).powi(2) + (b - q).powi(2) + (c - q).powi(2) + 2.0 * off;
    let p = (p2 / 6.0).sqrt();
    // B = (A - qI) / p; r = det(B) / 2 lies in [-1, 1] up to rounding.
    let inverse_p = 1.0 / p;
    let (ba, bb, bc, bd, be, bf) =
        ((a - q) * inverse_p, (b - q) * inverse_p, (c - q) * inverse_p, d * inverse_p, e * inverse_p, f * inverse_p);
    let determinant = ba * (bb * bc - bf * bf) - bd * (bd * bc - bf * be) + be * (bd * bf - bb * be);
    // phi = acos(r) / 3 lies in [0, pi / 3]; cos(phi + 2 pi / 3) = -cos(phi) / 2 -
    // sin(phi) sqrt(3) / 2. Polynomials instead of libm's acos and cos: this runs for every
    // classified voxel, and 1e-7 relative error is far below what the classifier resolves.
    let phi = acos_polynomial((determinant / 2.0).clamp(-1.0, 1.0)) / 3.0;
    let cos_phi = cos_polynomial(phi);
    let sin_phi = (1.0 - cos_phi * cos_phi).max(0.0).sqrt();
    let high = q + 2.0 * p * cos_phi;
    let low = q + 2.0 * p * (-0.5 * cos_phi - 0.5 * 3f64.sqrt() * sin_phi);
    let middle = 3.0 * q - high - low;
    [low as f32, middle as f32, high as f32]
}

/// acos(x) for x in [-1, 1], absolute error below 1e-7 (Abramowitz and Stegun 4.4.46:
/// sqrt(1 - x) times a degree-7 polynomial on [0, 1], and acos(-x) = pi - acos(x)).
pub fn acos_polynomial(x: f64) -> f64 {
    const COEFFICIENTS: [f64; 8] = [
        1.570_796_305_0,
        -0.214_598_801_6,
        0.088_978_987_4,
        -0.050_174_304_6,
        0.030_891_881_0,
        -0.017_088_125_6,
        0.006_670_090_1,
        -0.001_262_491_1,
    ];
    let magnitude = x.abs().min(1.0);
    let polynomial = COEFFICIENTS.iter().rev().fold(0.0, |sum, &c| sum * magnitude + c);
    let angle = (1.0 - magnitude).sqrt() * polynomial;
    if x < 0.0 { std::f64::consts::PI - angle } else { angle }
}

/// cos(x) for x in [0, pi / 3] (Taylor series to x^12: error below 1e-10 there).
pub fn cos_polynomial(x: f64) -> f64 {
    // 1 - x^2/2! + x^4/4! - ... + x^12/12!, by Horner in x^2: 1 - x^2/(2*1) (1 - x^2/(4*3) (...)).
    const INVERSE_STEPS: [f64; 6] = [1.0 / 2.0, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0, 1.0 / 90.0, 1.0 / 132.0];
    let x2 = x * x;
    INVERSE_STEPS.iter().rev().fold(1.0, |sum, &inverse| 1.0 - sum * x2 * inverse)
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
    // 0.0 + x == x, so starting from the first term sums in the same order as `edge`.
    interior.copy_from_slice(&input[..n - 2 * radius]);
    for d in 1..=2 * radius {
        for (o, &v) in interior.iter_mut().zip(&input[d..n - 2 * radius + d]) {
            *o += v;
        }
    }
    interior.iter_mut().for_each(|o| *o *= scale);
}

/// The same box across rows: row y of `out` is the mean of rows clamp(y + d) of `input`, whole
/// rows at a time (vectorised along x), summed in order of d.
fn box_across_lines(input: &[f32], out: &mut [f32], nx: usize, ny: usize, radius: usize) {
    let scale = 1.0 / (2 * radius + 1) as f32;
    for (y, out_row) in out.chunks_exact_mut(nx).enumerate() {
        for d in 0..=2 * radius {
            let source_y = (y + d).saturating_sub(radius).min(ny - 1);
            let source = &input[source_y * nx..][..nx];
            if d == 0 {
                out_row.copy_from_slice(source);
            } else {
                for (o, &s) in out_row.iter_mut().zip(source) {
                    *o += s;
                }
            }
        }
        out_row.iter_mut().for_each(|o| *o *= scale);
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
    let rows: Vec<Vec<(usize, [f32; MULTISCALE_DIM])>> = groups
        .par_iter()
        .map_init(
            || MultiscaleBlock::new(volume, scales),
            |block, group| {
                let voxels: Vec<[usize; 3]> = group.iter().map(|&(_, k)| position(indices[k])).collect();
                let core = std::array::from_fn(|a| {
                    let low = voxels.iter().map(|v| v[a]).min().unwrap_or(0);
                    let high = voxels.iter().map(|v| v[a]).max().unwrap_or(0);
                    low..high + 1
                });
                block.compute(volume, core);
                group
                    .iter()
                    .zip(&voxels)
                    .map(|(&(_, k), &voxel)| {
                        let mut row = [0f32; MULTISCALE_DIM];
                        block.features_at(voxel, &mut row);
                        (k, row)
                    })
                    .collect()
            },
        )
        .collect();
    let mut out = vec![0f32; indices.len() * dim];
    for (k, row) in rows.into_iter().flatten() {
        out[k * dim..(k + 1) * dim].copy_from_slice(&row[..dim]);
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
        out.clear();
        out.resize(selected.len() * dim, 0.0);
        if selected.is_empty() {
            return;
        }
        let [size_x, size_y, size_z] = self.volume.dims;
        // Blocks start on multiples of the depth, so that workers asked for neighbouring planes
        // in any order load each block once.
        let start = z - z % self.depth;
        let planes = start..(start + self.depth).min(size_z);
        let inside = |core: &[Range<usize>; 3]| {
            selected.iter().all(|&index| core[0].contains(&(index % size_x)) && core[1].contains(&(index / size_x)))
        };
        let current = self.loaded.as_ref().filter(|(range, _)| range.contains(&z));
        match current {
            Some(_) if inside(self.block.core()) => {}
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
                if !inside(self.block.core()) {
                    self.block.compute(self.volume, [0..size_x, 0..size_y, planes.clone()]);
                    self.loaded = Some((planes, true));
                }
            }
        }
        for (&index, row) in selected.iter().zip(out.chunks_exact_mut(dim)) {
            self.block.features_at([index % size_x, index / size_x, z], row);
        }
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

#[cfg(test)]
#[path = "multiscale_tests.rs"]
mod tests;
