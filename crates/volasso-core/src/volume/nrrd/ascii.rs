//! ASCII-encoded NRRD data: whitespace- or comma-separated decimal numbers, each stored exactly
//! in the header's type or refused with its line ([`VolumeError::AsciiValue`]).
//!
//! Never: clamps, rounds or truncates a value, or reads more values than the header promises.

use super::push_value;
use crate::volume::error::AsciiProblem;
use crate::volume::limits::{self, ReadLimits};
use crate::volume::{VolumeError, VoxelType};
use std::io::Read;
use std::path::Path;

/// The longest ASCII value read: more is not a number but a lying file.
const LONGEST_ASCII_VALUE: usize = 64;

/// Parses `voxel_count` whitespace- or comma-separated numbers from `text` (`available` bytes,
/// starting on line `first_line` of the file) into little-endian `voxel_type` bytes; fewer or
/// more values are errors, and so is a value `voxel_type` cannot hold ([`ascii_value`]).
pub(super) fn parse_ascii(
    text: impl Read,
    available: u64,
    first_line: u64,
    voxel_type: VoxelType,
    voxel_count: usize,
    limits: &ReadLimits,
    path: &Path,
) -> Result<Vec<u8>, VolumeError> {
    let size = voxel_type.size_bytes();
    let expected = (voxel_count * size) as u64;
    // Each value but the last needs a separator: at least two characters a value.
    let most_values = available.div_ceil(2);
    if voxel_count as u64 > most_values {
        return Err(VolumeError::CannotHold {
            expected,
            encoding: "ASCII",
            available,
            most: most_values * size as u64,
            path: path.to_path_buf(),
        });
    }
    limits::check_ceiling(expected, limits, path)?;
    let mut bytes = limits::reserve(voxel_count * size, path)?;
    let mut count = 0usize;
    let mut token: Vec<u8> = Vec::with_capacity(LONGEST_ASCII_VALUE);
    let mut finish = |token: &mut Vec<u8>, bytes: &mut Vec<u8>, line: u64| -> Result<(), VolumeError> {
        if token.is_empty() {
            return Ok(());
        }
        if count == voxel_count {
            return Err(VolumeError::ExtraData { expected, path: path.to_path_buf() });
        }
        let text = std::str::from_utf8(token).unwrap_or_default();
        let value = ascii_value(text, voxel_type).map_err(|problem| VolumeError::AsciiValue {
            value: String::from_utf8_lossy(token).chars().take(60).collect(),
            line,
            problem,
            voxel_type,
            path: path.to_path_buf(),
        })?;
        push_value(bytes, voxel_type, value);
        count += 1;
        token.clear();
        Ok(())
    };
    let mut line = first_line;
    for byte in std::io::BufReader::new(text).bytes() {
        let byte = byte.map_err(|e| VolumeError::io(e, path))?;
        if byte.is_ascii_whitespace() || byte == b',' {
            finish(&mut token, &mut bytes, line)?;
            if byte == b'\n' {
                line += 1;
            }
        } else if token.len() == LONGEST_ASCII_VALUE {
            return Err(VolumeError::header(
                "data",
                format!("a value is longer than {LONGEST_ASCII_VALUE} characters"),
                path,
            ));
        } else {
            token.push(byte);
        }
    }
    finish(&mut token, &mut bytes, line)?;
    if count < voxel_count {
        return Err(VolumeError::DataSize {
            expected: expected as usize,
            found: count * size,
            path: path.to_path_buf(),
        });
    }
    Ok(bytes)
}

/// One ASCII value as `voxel_type` holds it, or why it cannot: not a number, a fraction or a
/// value out of range for an integer type, a finite value beyond the float type's range.
/// Nothing is clamped, rounded or truncated: a 300 in a `uint8` file is a wrong header (or
/// wrong data), not 255. `nan` and `inf` are taken as written for float types.
pub(super) fn ascii_value(text: &str, voxel_type: VoxelType) -> Result<f64, AsciiProblem> {
    let value: f64 = text.parse().map_err(|_| AsciiProblem::NotANumber)?;
    let (low, high) = match voxel_type {
        VoxelType::U8 => (0.0, u8::MAX as f64),
        VoxelType::I8 => (i8::MIN as f64, i8::MAX as f64),
        VoxelType::U16 => (0.0, u16::MAX as f64),
        VoxelType::I16 => (i16::MIN as f64, i16::MAX as f64),
        VoxelType::U32 => (0.0, u32::MAX as f64),
        VoxelType::I32 => (i32::MIN as f64, i32::MAX as f64),
        VoxelType::F32 => (-(f32::MAX as f64), f32::MAX as f64),
        VoxelType::F64 => (f64::MIN, f64::MAX),
    };
    if !voxel_type.is_float() && (!value.is_finite() || value.fract() != 0.0) {
        return Err(AsciiProblem::NotWhole);
    }
    // `nan` and `inf` as written are values of a float type; an overflow to infinity is not.
    let written_non_finite = value.is_nan() || (value.is_infinite() && text.to_ascii_lowercase().contains("inf"));
    if voxel_type.is_float() && written_non_finite {
        return Ok(value);
    }
    if !(low..=high).contains(&value) {
        return Err(AsciiProblem::OutOfRange);
    }
    Ok(value)
}
