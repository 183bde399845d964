//! Box filters for the multi-scale cascade: the mean over 2r + 1 neighbours along a
//! row or across rows, borders clamped to the edge. Sums run in a fixed order of offset, so every
//! block of the volume gives the same bits for the same voxel whatever its extent.

/// `out[i]` = mean of `input[clamp(i + d)]` for d in -radius..=radius, summed in order of d
/// (the interior a whole row at a time, so that it vectorises).
pub(super) fn box_along_row(input: &[f32], out: &mut [f32], radius: usize) {
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
pub(super) fn box_across_lines(input: &[f32], out: &mut [f32], nx: usize, ny: usize, radius: usize) {
    let scale = 1.0 / (2 * radius + 1) as f32;
    for (y, out_row) in out.chunks_exact_mut(nx).enumerate() {
        let sources = BoxSources::new(radius, |d| &input[(y + d).saturating_sub(radius).min(ny - 1) * nx..][..nx]);
        sources.mean_into(out_row, scale);
    }
}

/// The 2r + 1 equally long runs of values a box filter of radius r averages, in order of
/// offset.
pub(super) struct BoxSources<'a> {
    runs: [&'a [f32]; BoxSources::MAX],
    count: usize,
}

impl<'a> BoxSources<'a> {
    /// Runs per box at most: radius 4, the cascade's widest.
    const MAX: usize = 9;
    /// Values summed side by side, in registers.
    const CHUNK: usize = 16;

    /// Runs `run(0)` to `run(2 * radius)`.
    pub(super) fn new(radius: usize, run: impl Fn(usize) -> &'a [f32]) -> BoxSources<'a> {
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
    pub(super) fn mean_into(&self, out: &mut [f32], scale: f32) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// The definition: the mean of the clamped neighbours, added in order of offset.
    fn clamped_mean(values: impl Fn(usize) -> f32, n: usize, i: usize, radius: usize) -> f32 {
        let mut sum = 0.0;
        for d in 0..=2 * radius {
            sum += values((i + d).saturating_sub(radius).min(n - 1));
        }
        sum * (1.0 / (2 * radius + 1) as f32)
    }

    #[test]
    fn rows_and_lines_give_the_bits_of_the_definition() {
        let mut rng = SplitMix64::new(5);
        for (n, radius) in [(1, 1), (2, 1), (3, 1), (8, 2), (9, 4), (37, 1), (40, 2), (53, 4)] {
            let row: Vec<f32> = (0..n).map(|_| 1000.0 * rng.next_f64() as f32).collect();
            let mut out = vec![0f32; n];
            box_along_row(&row, &mut out, radius);
            for (i, &o) in out.iter().enumerate() {
                assert_eq!(o.to_bits(), clamped_mean(|j| row[j], n, i, radius).to_bits(), "n {n} r {radius} i {i}");
            }
            // The same values as n rows of 3: the box runs down the columns.
            let (nx, ny) = (3, n);
            let plane: Vec<f32> = (0..nx * ny).map(|_| 1000.0 * rng.next_f64() as f32).collect();
            let mut out = vec![0f32; nx * ny];
            box_across_lines(&plane, &mut out, nx, ny, radius);
            for y in 0..ny {
                for x in 0..nx {
                    let expected = clamped_mean(|j| plane[x + nx * j], ny, y, radius);
                    assert_eq!(out[x + nx * y].to_bits(), expected.to_bits(), "n {n} r {radius} x {x} y {y}");
                }
            }
        }
    }

    #[test]
    fn the_avx2_variant_gives_the_portable_bits() {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2_fma() {
            let mut rng = SplitMix64::new(21);
            for radius in 0..=4 {
                let row: Vec<f32> = (0..100).map(|_| rng.next_f64() as f32).collect();
                let sources = BoxSources::new(radius, |d| &row[d..91 + d]);
                let (mut wide, mut portable) = ([0f32; 91], [0f32; 91]);
                // SAFETY: the CPU has AVX2 and FMA, checked above.
                unsafe { sources.mean_into_avx2(&mut wide, 0.2) };
                sources.mean_into_chunks(&mut portable, 0.2);
                assert_eq!(wide.map(f32::to_bits), portable.map(f32::to_bits), "radius {radius}");
            }
        }
    }
}
