//! PixelData of one slice, decoded to physical values (Hounsfield units for CT).
//!
//! [`read_slice`] reads the whole file (its element lengths checked first, [`super::bounds`]),
//! checks that the PixelData is exactly as long as the image matrix needs, takes the native
//! samples (8- or 16-bit words, as dicom-rs hands them over in machine order), masks each to
//! BitsStored bits, sign-extends it when PixelRepresentation is signed, and applies
//! RescaleSlope and RescaleIntercept.
//!
//! Never: decompresses (encapsulated data is refused by [`super::header`] and again here), or
//! looks at other slices.

use super::bounds::{self, Scope};
use super::header::{PixelFormat, SliceHeader};
use crate::volume::VolumeError;
use crate::volume::limits::ReadLimits;
use dicom_core::value::{PrimitiveValue, Value};
use dicom_dictionary_std::tags;

/// One decoded slice: `rows * columns` physical values, row by row (x fastest).
#[derive(Clone, Debug)]
pub(super) struct DecodedSlice {
    pub values: Vec<f32>,
    pub min: f32,
    pub max: f32,
}

/// Reads and decodes the pixel data of the file `header` was read from. The PixelData must be
/// exactly as long as Rows x Columns x SamplesPerPixel x BitsAllocated/8 x NumberOfFrames
/// (plus one padding byte when that is odd): a header that lies about the matrix (Rows 256 on
/// 512 x 512 data, BitsAllocated 8 on 16-bit data) is an error, never a sheared or garbled image.
pub(super) fn read_slice(header: &SliceHeader, limits: &ReadLimits) -> Result<DecodedSlice, VolumeError> {
    let path = header.path.as_path();
    let object = bounds::read_object(path, Scope::Whole, limits)?;
    let element = object
        .get(tags::PIXEL_DATA)
        .ok_or_else(|| VolumeError::MissingField { field: "PixelData", path: path.to_path_buf() })?;
    let format = header.pixel_format;
    let bits = usize::from(format.bits_allocated);
    let expected = bounds::pixel_data_bytes(header.rows, header.columns, 1, bits, 1).unwrap_or(u64::MAX);
    let matrix_error = |found: u64| VolumeError::Dicom {
        problem: format!(
            "PixelData holds {found} bytes but Rows {} x Columns {} x SamplesPerPixel 1 x BitsAllocated {bits} / 8 x NumberOfFrames 1 need {expected} (the header does not describe the pixels)",
            header.rows, header.columns
        ),
        path: path.to_path_buf(),
    };
    let found = match element.value() {
        Value::Primitive(PrimitiveValue::U16(words)) => words.len() as u64 * 2,
        Value::Primitive(PrimitiveValue::I16(words)) => words.len() as u64 * 2,
        Value::Primitive(PrimitiveValue::U8(bytes)) => bytes.len() as u64,
        Value::Primitive(PrimitiveValue::Empty) => 0,
        Value::PixelSequence(_) => {
            return Err(VolumeError::Unsupported {
                what: "encapsulated (compressed) DICOM PixelData",
                value: object.meta().transfer_syntax().to_string(),
                path: path.to_path_buf(),
            });
        }
        _ => {
            return Err(VolumeError::header(
                "PixelData",
                format!("its value (VR {}) does not match BitsAllocated {}", element.vr(), format.bits_allocated),
                path,
            ));
        }
    };
    if !(found == expected || (expected % 2 == 1 && found == expected + 1)) {
        return Err(matrix_error(found));
    }
    let pixel_count = header.rows * header.columns;
    let stored: Vec<u16> = match element.value() {
        Value::Primitive(PrimitiveValue::U16(words)) if format.bits_allocated == 16 => words[..pixel_count].to_vec(),
        Value::Primitive(PrimitiveValue::I16(words)) if format.bits_allocated == 16 => {
            words[..pixel_count].iter().map(|w| *w as u16).collect()
        }
        Value::Primitive(PrimitiveValue::U16(words)) => {
            // 8-bit samples read as OW (implicit VR): each word holds two samples, low byte first.
            words.iter().flat_map(|w| w.to_le_bytes()).take(pixel_count).map(u16::from).collect()
        }
        Value::Primitive(PrimitiveValue::U8(bytes)) if format.bits_allocated == 8 => {
            bytes[..pixel_count].iter().map(|b| u16::from(*b)).collect()
        }
        Value::Primitive(PrimitiveValue::U8(bytes)) => {
            // 16-bit samples sent as OB (explicit VR) keep the file's little-endian order.
            bytes[..pixel_count * 2].chunks_exact(2).map(|pair| u16::from_le_bytes([pair[0], pair[1]])).collect()
        }
        _ => return Err(matrix_error(found)),
    };
    Ok(to_physical(&stored, format, header.rescale.slope, header.rescale.intercept))
}

/// Masks, sign-extends and rescales stored samples.
fn to_physical(stored: &[u16], format: PixelFormat, slope: f64, intercept: f64) -> DecodedSlice {
    // Shifting the stored bits to the top of an i32 and back masks the unused high bits and,
    // for signed data, extends the sign, without a branch per sample (so the loop vectorises).
    let unused_bits = 32 - u32::from(format.bits_stored);
    let integers: Vec<i32> = stored
        .iter()
        .map(|&sample| {
            let top = u32::from(sample) << unused_bits;
            if format.signed { (top as i32) >> unused_bits } else { (top >> unused_bits) as i32 }
        })
        .collect();
    let (low, high) = integers.iter().fold((i32::MAX, i32::MIN), |(low, high), &v| (low.min(v), high.max(v)));
    let rescale = |integer: i32| (f64::from(integer) * slope + intercept) as f32;
    let values: Vec<f32> = integers.iter().map(|&integer| rescale(integer)).collect();
    // The rescale is monotonic, so the extremes of the values are those of the samples.
    let (min, max) = if values.is_empty() {
        (0.0, 0.0)
    } else {
        let (a, b) = (rescale(low), rescale(high));
        (a.min(b), a.max(b))
    };
    DecodedSlice { values, min, max }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn format(bits_allocated: u16, bits_stored: u16, signed: bool) -> PixelFormat {
        PixelFormat { bits_allocated, bits_stored, signed }
    }

    #[test]
    fn signed_16_bit_samples_are_twos_complement() {
        let stored = [0u16, 1, 0xFFFF, 0x8000, 0x7FFF];
        let slice = to_physical(&stored, format(16, 16, true), 1.0, 0.0);
        assert_eq!(slice.values, vec![0.0, 1.0, -1.0, -32768.0, 32767.0]);
        assert_eq!((slice.min, slice.max), (-32768.0, 32767.0));
    }

    #[test]
    fn twelve_bit_samples_ignore_the_high_bits_and_sign_extend_from_bit_11() {
        // 0xF000 are overlay bits in old CT files; 0x0800 is the sign bit of a 12-bit sample.
        let stored = [0xF001u16, 0x0FFF, 0x0800];
        let unsigned = to_physical(&stored, format(16, 12, false), 1.0, -1024.0);
        assert_eq!(unsigned.values, vec![-1023.0, 3071.0, 1024.0]);
        let signed = to_physical(&stored, format(16, 12, true), 1.0, 0.0);
        assert_eq!(signed.values, vec![1.0, -1.0, -2048.0]);
    }

    #[test]
    fn rescale_is_applied_after_decoding() {
        let slice = to_physical(&[10u16, 200], format(8, 8, false), 0.5, -3.0);
        assert_eq!(slice.values, vec![2.0, 97.0]);
    }
}
