//! Where a volume's foreground is, a row at a time: the voxels at or above a threshold
//! (the background threshold of `segmentation`). Labelling a scan visits every row of every
//! plane, and most rows are air; [`ForegroundRows`] finds the foreground span of every row in
//! one parallel pass, so that the passes after it decode and scan only the rows that matter.
//!
//! Never: decides the threshold (that is `segmentation::Background`).

use super::Volume;
use rayon::prelude::*;
use std::ops::RangeInclusive;

/// Whether any of `values` is at least `threshold` (NaN never is), in chunks the compiler
/// vectorises: most rows of a scan are air, and this is how scans skip them.
#[inline(always)]
pub fn any_at_or_above(values: &[f32], threshold: f32) -> bool {
    values.chunks(64).any(|chunk| chunk.iter().fold(false, |found, &value| found | (value >= threshold)))
}

/// The span from the first to the last of `values` that is at least `threshold` (NaN never
/// is), or `None` when there is none. Tested a chunk at a time like [`any_at_or_above`], so a
/// mostly-air row costs a few vector compares, not a branch per voxel.
/// Generic so that stored bytes can be scanned as they are (see [`ForegroundRows::find`]).
#[inline]
fn foreground_span<T: PartialOrd + Copy>(values: &[T], threshold: T) -> Option<RangeInclusive<usize>> {
    // A cache line per test: 16 f32 values, 64 stored bytes.
    let chunk_len = 64 / std::mem::size_of::<T>().clamp(1, 64);
    let has_foreground = |chunk: &[T]| chunk.iter().fold(false, |found, &value| found | (value >= threshold));
    let first_chunk = values.chunks(chunk_len).position(has_foreground)?;
    let last_chunk = values.chunks(chunk_len).rposition(has_foreground).unwrap_or(first_chunk);
    let in_chunk = |chunk: usize| &values[chunk * chunk_len..((chunk + 1) * chunk_len).min(values.len())];
    let first = in_chunk(first_chunk).iter().position(|&value| value >= threshold).unwrap_or(0);
    let last = in_chunk(last_chunk).iter().rposition(|&value| value >= threshold).unwrap_or(0);
    Some(first_chunk * chunk_len + first..=last_chunk * chunk_len + last)
}

/// The foreground span of every row (fixed y and z) of a volume at one threshold.
#[derive(Clone, Debug)]
pub struct ForegroundRows {
    size_y: usize,
    size_z: usize,
    /// Per row, y fastest: the first and last foreground x, or `EMPTY`.
    spans: Vec<[usize; 2]>,
}

/// A row without foreground (first > last).
const EMPTY: [usize; 2] = [1, 0];

impl ForegroundRows {
    /// Scans `volume` once, planes in parallel. Bytes (the common 8-bit scan, with an
    /// increasing scale) are compared as stored; other types are decoded a row at a time.
    pub fn find(volume: &Volume, threshold: f32) -> ForegroundRows {
        let [size_x, size_y, size_z] = volume.dims;
        let mut spans = vec![EMPTY; size_y * size_z];
        let stored_threshold = stored_byte_threshold(volume, threshold);
        spans.par_chunks_mut(size_y.max(1)).enumerate().for_each_init(
            || vec![0f32; size_x],
            |row_values, (z, plane_spans)| {
                for (y, span) in plane_spans.iter_mut().enumerate() {
                    let start = size_x * (y + size_y * z);
                    let found = match stored_threshold {
                        Some(StoredThreshold::Byte(byte)) => {
                            foreground_span(&volume.bytes.as_slice()[start..start + size_x], byte)
                        }
                        Some(StoredThreshold::AboveEveryByte) => None,
                        None => {
                            volume.read_f32(start, row_values);
                            foreground_span(row_values, threshold)
                        }
                    };
                    if let Some(found) = found {
                        *span = [*found.start(), *found.end()];
                    }
                }
            },
        );
        ForegroundRows { size_y, size_z, spans }
    }

    /// Every row entirely foreground: what labelling without a background threshold uses.
    pub fn every_voxel(dims: [usize; 3]) -> ForegroundRows {
        let [size_x, size_y, size_z] = dims;
        let full = match size_x.checked_sub(1) {
            Some(last) => [0, last],
            None => EMPTY,
        };
        ForegroundRows { size_y, size_z, spans: vec![full; size_y * size_z] }
    }

    /// The first to the last foreground x of row (`y`, `z`); `None` when it has none (or is
    /// outside the volume).
    #[inline]
    pub fn span(&self, y: usize, z: usize) -> Option<RangeInclusive<usize>> {
        if y >= self.size_y || z >= self.size_z {
            return None;
        }
        let [first, last] = self.spans[y + self.size_y * z];
        (first <= last).then_some(first..=last)
    }

    /// Rows per plane.
    pub fn size_y(&self) -> usize {
        self.size_y
    }

    /// Whether row (`y`, `z`) or one of its eight neighbours in y and z holds foreground: the
    /// rows a foreground voxel's 3x3x3 neighbourhood reads.
    pub fn near_foreground(&self, y: usize, z: usize) -> bool {
        let around = |p: usize, size: usize| p.saturating_sub(1)..(p + 2).min(size);
        around(z, self.size_z).any(|z| around(y, self.size_y).any(|y| self.span(y, z).is_some()))
    }
}

/// What a stored byte is compared with in place of its physical value.
#[derive(Clone, Copy, Debug, PartialEq)]
enum StoredThreshold {
    /// Physical value >= the threshold exactly when stored byte >= this.
    Byte(u8),
    /// No byte's physical value reaches the threshold.
    AboveEveryByte,
}

/// For a volume of `u8` voxels whose scale increases (identity included): the stored byte
/// that stands for `threshold`. The map from byte to physical value (`read_f32`'s, rounding
/// included) then never decreases, so the smallest byte that reaches the threshold splits the
/// bytes as the threshold splits their values. `None` for other volumes.
fn stored_byte_threshold(volume: &Volume, threshold: f32) -> Option<StoredThreshold> {
    let scale = volume.scale;
    if volume.voxel_type != super::VoxelType::U8 || !(scale.slope > 0.0 && scale.intercept.is_finite()) {
        return None;
    }
    let mut physical = [0f32; 1];
    let reaches = |byte: u8, physical: &mut [f32; 1]| {
        super::convert_bytes(&[byte], scale, physical);
        physical[0] >= threshold
    };
    Some(match (0..=u8::MAX).find(|&byte| reaches(byte, &mut physical)) {
        Some(byte) => StoredThreshold::Byte(byte),
        None => StoredThreshold::AboveEveryByte,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{ByteOrder, ValueScale, VoxelBytes, VoxelType, convert_bytes};
    use std::path::Path;

    /// A little-endian volume of `voxel_type` over `bytes`, stored values mapped by `scale`.
    fn scaled_volume(dims: [usize; 3], voxel_type: VoxelType, scale: ValueScale, bytes: Vec<u8>) -> Volume {
        let bytes = VoxelBytes::Owned(bytes);
        Volume::new(dims, [1.0; 3], voxel_type, ByteOrder::Little, scale, bytes, Path::new("t")).unwrap()
    }

    #[test]
    fn any_at_or_above_finds_one_voxel_anywhere_and_ignores_nan() {
        let mut values = vec![0.0f32; 200];
        assert!(!any_at_or_above(&values, 1.0));
        values[137] = f32::NAN;
        assert!(!any_at_or_above(&values, 1.0));
        values[199] = 1.0;
        assert!(any_at_or_above(&values, 1.0));
    }

    #[test]
    fn foreground_span_is_the_first_to_the_last_foreground_value() {
        for length in [0, 1, 15, 16, 17, 47, 200] {
            for first in 0..length {
                for last in (first..length).step_by(7).chain([length - 1]) {
                    let mut values = vec![0.0f32; length];
                    values[first] = 2.0;
                    values[last] = 1.0;
                    if first + 1 < last {
                        values[first + 1] = f32::NAN;
                    }
                    assert_eq!(foreground_span(&values, 1.0), Some(first..=last), "{length} {first} {last}");
                }
            }
            assert_eq!(foreground_span(&vec![f32::NAN; length], 1.0), None);
            assert_eq!(foreground_span(&vec![0.5; length], 1.0), None);
        }
    }

    #[test]
    fn rows_hold_the_spans_of_a_scaled_volume() {
        // 5 x 4 x 3 voxels of i16, scaled by 2: stored 3 is physical 6, at the threshold.
        let dims = [5, 4, 3];
        let index = |x: usize, y: usize, z: usize| x + 5 * (y + 4 * z);
        let mut stored = [0i16; 60];
        stored[index(1, 2, 1)] = 3;
        stored[index(4, 2, 1)] = 7;
        stored[index(0, 3, 2)] = 2; // 4 is below the threshold
        let bytes = stored.iter().flat_map(|v| v.to_le_bytes()).collect();
        let scale = ValueScale { slope: 2.0, intercept: 0.0 };
        let volume = scaled_volume(dims, VoxelType::I16, scale, bytes);
        let rows = ForegroundRows::find(&volume, 6.0);
        for z in 0..3 {
            for y in 0..4 {
                let expected = ((y, z) == (2, 1)).then_some(1..=4);
                assert_eq!(rows.span(y, z), expected, "row {y} {z}");
            }
        }
        assert_eq!(rows.span(4, 0), None);
        assert!(rows.near_foreground(2, 1) && rows.near_foreground(3, 2) && rows.near_foreground(1, 0));
        assert!(!rows.near_foreground(0, 0) && !rows.near_foreground(0, 2));
        let every = ForegroundRows::every_voxel(dims);
        assert_eq!(every.span(3, 2), Some(0..=4));
    }

    #[test]
    fn stored_bytes_give_the_spans_of_the_decoded_values() {
        // Bytes compared as stored must split rows exactly as their physical values do, for
        // increasing scales (the byte path) and the others (the decoding path), at thresholds
        // between, on and beyond the values.
        let dims = [37, 6, 5];
        let mut state = 7u64;
        let bytes: Vec<u8> = (0..dims.iter().product::<usize>())
            .map(|_| {
                state = crate::rng::hash64(state, 3);
                // Mostly air, some bright voxels.
                if state % 5 == 0 { (state >> 8) as u8 } else { (state >> 8) as u8 % 20 }
            })
            .collect();
        let scales = [
            ValueScale::IDENTITY,
            ValueScale { slope: 0.37, intercept: -5.1 },
            ValueScale { slope: 1.0 / 3.0, intercept: 1e-7 },
            ValueScale { slope: -2.0, intercept: 100.0 },
        ];
        for scale in scales {
            let volume = scaled_volume(dims, VoxelType::U8, scale, bytes.clone());
            let mut row = vec![0f32; dims[0]];
            for threshold in [-1e9, -5.1, 0.0, 4.0, 4.07, 19.0, 33.3, 60.0, 85.0, 255.0, 1e9, f32::NAN] {
                let rows = ForegroundRows::find(&volume, threshold);
                for z in 0..dims[2] {
                    for y in 0..dims[1] {
                        volume.read_f32(dims[0] * (y + dims[1] * z), &mut row);
                        let expected = foreground_span(&row, threshold);
                        assert_eq!(rows.span(y, z), expected, "{scale:?} {threshold} row {y} {z}");
                    }
                }
            }
        }
        // Exact thresholds of the byte path: physical values 0.37 * b - 5.1 as f32.
        let scale = ValueScale { slope: 0.37, intercept: -5.1 };
        let volume = scaled_volume(dims, VoxelType::U8, scale, bytes);
        for byte in [0u8, 1, 17, 200, 255] {
            let mut physical = [0f32];
            convert_bytes(&[byte], scale, &mut physical);
            assert_eq!(stored_byte_threshold(&volume, physical[0]), Some(StoredThreshold::Byte(byte)));
        }
        assert_eq!(stored_byte_threshold(&volume, 1000.0), Some(StoredThreshold::AboveEveryByte));
    }
}
