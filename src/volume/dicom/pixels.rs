//! PixelData of one file, decoded to physical values (Hounsfield units for CT), one slice per
//! frame.
//!
//! [`read_frames`] reads the whole file (its element lengths checked first, [`super::bounds`];
//! a deflated data set inflated there). Native PixelData must be exactly as long as the image
//! matrix needs, and its samples are taken as dicom-object hands them over (8- or 16-bit words
//! in machine order). Encapsulated (compressed) PixelData is decoded frame by frame by the
//! decoder that dicom-rs's transfer syntax registry holds for the file's syntax (JPEG through
//! jpeg-decoder, JPEG-LS through CharLS, JPEG 2000 through OpenJPEG, RLE in dicom-rs), and each
//! decoded frame must be exactly Rows x Columns x BitsAllocated/8 bytes. Each sample is then
//! masked to BitsStored bits, sign-extended when PixelRepresentation is signed, and rescaled
//! with RescaleSlope and RescaleIntercept: compressed and uncompressed copies of a series give
//! the same values.
//!
//! dicom-pixeldata's `decode_pixel_data` is not used: besides the same registry decoders it
//! requires attributes that do not change a voxel (HighBit, matching WindowCenter and
//! WindowWidth counts), so files this reader opens would fail there.
//!
//! A compressed frame whose own header declares another image size than the DICOM header is
//! refused before its decoder runs ([`codestream`]): decoders allocate what that header says.
//!
//! Never: looks at other files, or lets a decoder's panic escape (it becomes an error).

use super::bounds::{self, Scope};
use super::codestream;
use super::header::{PixelFormat, SliceHeader};
use crate::volume::VolumeError;
use crate::volume::limits::ReadLimits;
use dicom_core::value::{PrimitiveValue, Value};
use dicom_dictionary_std::tags;
use dicom_encoding::transfer_syntax::{Codec, TransferSyntaxIndex};
use dicom_object::DefaultDicomObject;
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use std::path::Path;

/// One decoded slice: `rows * columns` physical values, row by row (x fastest).
#[derive(Clone, Debug)]
pub(super) struct DecodedSlice {
    pub values: Vec<f32>,
    pub min: f32,
    pub max: f32,
}

/// Reads and decodes the pixel data of the one file that `header` was read from.
#[cfg(test)]
pub(super) fn read_slice(header: &SliceHeader, limits: &ReadLimits) -> Result<DecodedSlice, VolumeError> {
    let mut slices = read_frames(&[header], limits)?;
    slices.pop().ok_or_else(|| VolumeError::MissingField { field: "PixelData", path: header.path.clone() })
}

/// Decodes the frames `headers` describe, all of one file (in the order given). The PixelData
/// must hold exactly Rows x Columns x SamplesPerPixel x BitsAllocated/8 x NumberOfFrames bytes
/// (plus one padding byte when that is odd), or for compressed data decode to exactly that
/// per frame: a header that lies about the matrix (Rows 256 on 512 x 512 data, BitsAllocated 8
/// on 16-bit data) is an error, never a sheared or garbled image.
pub(super) fn read_frames(headers: &[&SliceHeader], limits: &ReadLimits) -> Result<Vec<DecodedSlice>, VolumeError> {
    let Some(first) = headers.first() else { return Ok(Vec::new()) };
    let path = first.path.as_path();
    let object = bounds::read_object(path, Scope::Whole, limits)?;
    let element = object
        .get(tags::PIXEL_DATA)
        .ok_or_else(|| VolumeError::MissingField { field: "PixelData", path: path.to_path_buf() })?;
    let format = first.pixel_format;
    let bits = usize::from(format.bits_allocated);
    let frames = first.frames_in_file as usize;
    let frame_bytes = bounds::pixel_data_bytes(first.rows, first.columns, 1, bits, 1).unwrap_or(u64::MAX);
    let expected = bounds::pixel_data_bytes(first.rows, first.columns, 1, bits, frames).unwrap_or(u64::MAX);
    let matrix_error = |found: u64, what: &str| VolumeError::Dicom {
        problem: format!(
            "{what} holds {found} bytes but Rows {} x Columns {} x SamplesPerPixel 1 x BitsAllocated {bits} / 8 x NumberOfFrames {} need {} (the header does not describe the pixels)",
            first.rows,
            first.columns,
            if what == "PixelData" { frames } else { 1 },
            if what == "PixelData" { expected } else { frame_bytes },
        ),
        path: path.to_path_buf(),
    };
    let pixel_count = first.rows * first.columns;
    if let Value::PixelSequence(_) = element.value() {
        let mut slices = Vec::with_capacity(headers.len());
        for header in headers {
            let bytes = decode_frame(&object, header.frame, header, path)?;
            if bytes.len() as u64 != frame_bytes {
                return Err(matrix_error(bytes.len() as u64, "a decoded frame"));
            }
            let stored: Vec<u16> = if bits == 8 {
                bytes.iter().map(|b| u16::from(*b)).collect()
            } else {
                // Decoders write native samples in little-endian order.
                bytes.chunks_exact(2).map(|pair| u16::from_le_bytes([pair[0], pair[1]])).collect()
            };
            slices.push(to_physical(&stored, format, header.rescale.slope, header.rescale.intercept));
        }
        return Ok(slices);
    }
    let found = match element.value() {
        Value::Primitive(PrimitiveValue::U16(words)) => words.len() as u64 * 2,
        Value::Primitive(PrimitiveValue::I16(words)) => words.len() as u64 * 2,
        Value::Primitive(PrimitiveValue::U8(bytes)) => bytes.len() as u64,
        Value::Primitive(PrimitiveValue::Empty) => 0,
        _ => {
            return Err(VolumeError::header(
                "PixelData",
                format!("its value (VR {}) does not match BitsAllocated {}", element.vr(), format.bits_allocated),
                path,
            ));
        }
    };
    if !(found == expected || (expected % 2 == 1 && found == expected + 1)) {
        return Err(matrix_error(found, "PixelData"));
    }
    let mut slices = Vec::with_capacity(headers.len());
    for header in headers {
        let range = header.frame as usize * pixel_count..(header.frame as usize + 1) * pixel_count;
        let stored: Vec<u16> = match element.value() {
            Value::Primitive(PrimitiveValue::U16(words)) if bits == 16 => words[range].to_vec(),
            Value::Primitive(PrimitiveValue::I16(words)) if bits == 16 => {
                words[range].iter().map(|w| *w as u16).collect()
            }
            Value::Primitive(PrimitiveValue::U16(words)) => {
                // 8-bit samples read as OW (implicit VR): each word holds two samples, low byte first.
                let bytes = words.iter().flat_map(|w| w.to_le_bytes());
                bytes.skip(range.start).take(pixel_count).map(u16::from).collect()
            }
            Value::Primitive(PrimitiveValue::U8(bytes)) if bits == 8 => {
                bytes[range].iter().map(|b| u16::from(*b)).collect()
            }
            Value::Primitive(PrimitiveValue::U8(bytes)) => {
                // 16-bit samples sent as OB (explicit VR) keep the file's little-endian order.
                bytes[range.start * 2..range.end * 2]
                    .chunks_exact(2)
                    .map(|pair| u16::from_le_bytes([pair[0], pair[1]]))
                    .collect()
            }
            _ => return Err(matrix_error(found, "PixelData")),
        };
        slices.push(to_physical(&stored, format, header.rescale.slope, header.rescale.intercept));
    }
    Ok(slices)
}

/// One frame of encapsulated PixelData, decoded by the registry's decoder for the file's
/// transfer syntax; a decoder that panics on a hostile stream gives an error.
fn decode_frame(
    object: &DefaultDicomObject,
    frame: u32,
    header: &SliceHeader,
    path: &Path,
) -> Result<Vec<u8>, VolumeError> {
    let uid = object.meta().transfer_syntax();
    let unsupported = || VolumeError::Unsupported {
        what: "encapsulated DICOM PixelData without a decoder in this build",
        value: uid.to_string(),
        path: path.to_path_buf(),
    };
    let syntax = TransferSyntaxRegistry.get(uid).ok_or_else(unsupported)?;
    let Codec::EncapsulatedPixelData(Some(decoder), _) = syntax.codec() else {
        return Err(unsupported());
    };
    check_declared_size(object, frame, header, path)?;
    let mut bytes = Vec::new();
    let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        decoder.decode_frame(object, frame, &mut bytes).map_err(|error| error.to_string())
    }));
    match decoded {
        Ok(Ok(())) => Ok(bytes),
        Ok(Err(problem)) => Err(VolumeError::Dicom {
            problem: format!("frame {} of the {} PixelData cannot be decoded ({problem})", frame + 1, syntax.name()),
            path: path.to_path_buf(),
        }),
        Err(_) => Err(VolumeError::Dicom {
            problem: format!("the {} decoder failed inside on frame {}", syntax.name(), frame + 1),
            path: path.to_path_buf(),
        }),
    }
}

/// Refuses a compressed frame whose own header declares another size than Rows x Columns x 1
/// sample, before its decoder allocates what that header says ([`codestream`]).
fn check_declared_size(
    object: &DefaultDicomObject,
    frame: u32,
    header: &SliceHeader,
    path: &Path,
) -> Result<(), VolumeError> {
    let Some(Value::PixelSequence(sequence)) = object.get(tags::PIXEL_DATA).map(|element| element.value()) else {
        return Ok(());
    };
    let fragments = sequence.fragments();
    // The frame's first fragment: one fragment per frame, a single frame in any number, or
    // where the basic offset table says.
    let first = if fragments.len() == header.frames_in_file as usize {
        fragments.get(frame as usize).map(Vec::as_slice)
    } else if header.frames_in_file == 1 {
        fragments.first().map(Vec::as_slice)
    } else {
        first_fragment_by_offset(sequence.offset_table(), fragments, frame)
    };
    let Some(declared) = first.and_then(|bytes| codestream::declared_size(object.meta().transfer_syntax(), bytes))
    else {
        return Ok(());
    };
    if (declared.width as usize, declared.height as usize, declared.components) != (header.columns, header.rows, 1) {
        return Err(VolumeError::Dicom {
            problem: format!(
                "frame {} is compressed as {} x {} pixels with {} components, but Columns {} x Rows {} x SamplesPerPixel 1 say otherwise",
                frame + 1,
                declared.width,
                declared.height,
                declared.components,
                header.columns,
                header.rows
            ),
            path: path.to_path_buf(),
        });
    }
    Ok(())
}

/// The fragment that starts `frame` by the basic offset table: the byte offset of the frame's
/// first item, counted from the first item, each item being an 8-byte tag and length then its
/// bytes (PS3.5 A.4). `None` without a table or when no item starts there.
fn first_fragment_by_offset<'a>(offsets: &[u32], fragments: &'a [Vec<u8>], frame: u32) -> Option<&'a [u8]> {
    let wanted = u64::from(*offsets.get(frame as usize)?);
    let mut position = 0u64;
    for fragment in fragments {
        if position == wanted {
            return Some(fragment);
        }
        position += 8 + fragment.len() as u64;
    }
    None
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
