//! PixelData of one slice, decoded to physical values (Hounsfield units for CT).
//!
//! [`read_slice`] opens the whole file, takes its native PixelData (8- or 16-bit words, as
//! dicom-rs hands them over in machine order), masks each sample to BitsStored bits,
//! sign-extends it when PixelRepresentation is signed, and applies RescaleSlope and
//! RescaleIntercept.
//!
//! Never: decompresses (encapsulated data is refused by [`super::header`] and again here), or
//! looks at other slices.

use super::header::{PixelFormat, SliceHeader};
use crate::volume::VolumeError;
use dicom_core::value::{PrimitiveValue, Value};
use dicom_dictionary_std::tags;
use dicom_object::OpenFileOptions;

/// One decoded slice: `rows * columns` physical values, row by row (x fastest).
#[derive(Clone, Debug)]
pub(super) struct DecodedSlice {
    pub values: Vec<f32>,
    pub min: f32,
    pub max: f32,
}

/// Reads and decodes the pixel data of the file `header` was read from.
pub(super) fn read_slice(header: &SliceHeader) -> Result<DecodedSlice, VolumeError> {
    let path = header.path.as_path();
    let object = OpenFileOptions::new().open_file(path).map_err(|error| VolumeError::Dicom {
        problem: format!("unreadable DICOM file ({error})"),
        path: path.to_path_buf(),
    })?;
    let element = object
        .get(tags::PIXEL_DATA)
        .ok_or_else(|| VolumeError::MissingField { field: "PixelData", path: path.to_path_buf() })?;
    let pixel_count = header.rows * header.columns;
    let format = header.pixel_format;
    let bytes_per_sample = usize::from(format.bits_allocated / 8);
    let size_error = |found_bytes: usize| VolumeError::DataSize {
        expected: pixel_count * bytes_per_sample,
        found: found_bytes,
        path: path.to_path_buf(),
    };
    let stored: Vec<u16> = match element.value() {
        Value::Primitive(PrimitiveValue::U16(words)) if format.bits_allocated == 16 => {
            let words = words.get(..pixel_count).ok_or(size_error(words.len() * 2))?;
            words.to_vec()
        }
        Value::Primitive(PrimitiveValue::I16(words)) if format.bits_allocated == 16 => {
            let words = words.get(..pixel_count).ok_or(size_error(words.len() * 2))?;
            words.iter().map(|w| *w as u16).collect()
        }
        Value::Primitive(PrimitiveValue::U16(words)) => {
            // 8-bit samples read as OW (implicit VR): each word holds two samples, low byte first.
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            let bytes = bytes.get(..pixel_count).ok_or(size_error(bytes.len()))?;
            bytes.iter().map(|b| u16::from(*b)).collect()
        }
        Value::Primitive(PrimitiveValue::U8(bytes)) => {
            let bytes = bytes.get(..pixel_count * bytes_per_sample).ok_or(size_error(bytes.len()))?;
            if bytes_per_sample == 1 {
                bytes.iter().map(|b| u16::from(*b)).collect()
            } else {
                // 16-bit samples sent as OB (explicit VR) keep the file's little-endian order.
                bytes.chunks_exact(2).map(|pair| u16::from_le_bytes([pair[0], pair[1]])).collect()
            }
        }
        Value::Primitive(PrimitiveValue::Empty) => return Err(size_error(0)),
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
