//! PixelData of one file, decoded to physical values (Hounsfield units for CT), one slice per
//! frame.
//!
//! [`read_frames`] reads the whole file (its element lengths checked first, [`super::bounds`];
//! a deflated data set inflated there). Native PixelData must be exactly as long as the image
//! matrix needs, and its samples are taken as dicom-object hands them over (8- or 16-bit words
//! in machine order); zero padding after them, less than a frame of it, is ignored and reported
//! (a slice's `note`). Encapsulated (compressed) PixelData is decoded frame by frame by the
//! decoder that dicom-rs's transfer syntax registry holds for the file's syntax (JPEG through
//! jpeg-decoder, JPEG-LS through CharLS, JPEG 2000 through OpenJPEG, RLE in dicom-rs), or for
//! 12-bit lossy JPEG by libjpeg-turbo ([`jpeg12`]), and each decoded frame must be exactly
//! Rows x Columns x BitsAllocated/8 bytes. Each sample is then masked to BitsStored bits,
//! sign-extended when PixelRepresentation is signed, and rescaled with RescaleSlope and
//! RescaleIntercept, or mapped through the Modality LUT where the file has one
//! ([`super::modality_lut`]): compressed and uncompressed copies of a series give the same
//! values.
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
use super::jpeg12;
use super::modality_lut::ModalityLut;
use crate::volume::limits::ReadLimits;
use crate::volume::{ValueScale, VolumeError};
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
    /// What decoding tolerated in this slice's file, one sentence (zero padding after native
    /// PixelData, a decoder's harmless warning); set on the first frame decoded of a file.
    pub note: Option<String>,
}

/// Reads and decodes the pixel data of the one file that `header` was read from.
#[cfg(test)]
pub(super) fn read_slice(header: &SliceHeader, limits: &ReadLimits) -> Result<DecodedSlice, VolumeError> {
    let mut slices = read_frames(&[header], limits)?;
    slices.pop().ok_or_else(|| VolumeError::MissingField { field: "PixelData", path: header.path.clone() })
}

/// Decodes the frames `headers` describe, all of one file (in the order given). The PixelData
/// must hold exactly Rows x Columns x SamplesPerPixel x BitsAllocated/8 x NumberOfFrames bytes
/// (plus one padding byte when that is odd, or zero padding shorter than a frame), or for
/// compressed data decode to exactly that
/// per frame: a header that lies about the matrix (Rows 256 on 512 x 512 data, BitsAllocated 8
/// on 16-bit data) is an error, never a sheared or garbled image.
pub(super) fn read_frames(headers: &[&SliceHeader], limits: &ReadLimits) -> Result<Vec<DecodedSlice>, VolumeError> {
    let Some(first) = headers.first() else { return Ok(Vec::new()) };
    let path = first.path.as_path();
    let object = super::unknown_vr::read_object(path, Scope::Whole, limits)?;
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
        let mut note = None;
        for header in headers {
            let (bytes, warning) = decode_frame(&object, header.frame, header, path)?;
            if bytes.len() as u64 != frame_bytes {
                return Err(matrix_error(bytes.len() as u64, "a decoded frame"));
            }
            let stored: Vec<u16> = if bits == 8 {
                bytes.iter().map(|b| u16::from(*b)).collect()
            } else {
                // Decoders write native samples in little-endian order.
                bytes.chunks_exact(2).map(|pair| u16::from_le_bytes([pair[0], pair[1]])).collect()
            };
            slices.push(to_physical(&stored, format, header.rescale, header.modality_lut.as_deref()));
            note =
                note.or(warning.map(|warning| format!("the JPEG decoder warned \"{warning}\" (no pixel is affected)")));
        }
        if let Some(first) = slices.first_mut() {
            first.note = note;
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
    // Beyond the even length the matrix needs, PixelData may only hold zero padding, less than
    // a frame of it (some writers pad to a block size): more, or anything but zeros, means the
    // header does not describe the pixels.
    let needed = expected + expected % 2;
    let padding_bytes = found.saturating_sub(needed);
    if !(found == expected || found == needed || (padding_bytes > 0 && padding_bytes < frame_bytes))
        || !zero_after(element.value(), needed)
    {
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
        slices.push(to_physical(&stored, format, header.rescale, header.modality_lut.as_deref()));
    }
    if let Some(first) = slices.first_mut()
        && padding_bytes > 0
    {
        first.note =
            Some(format!("its PixelData ends in {padding_bytes} bytes of zero padding after the image, ignored"));
    }
    Ok(slices)
}

/// True when every byte of native PixelData from byte `start` on is zero.
fn zero_after(value: &Value<dicom_object::InMemDicomObject, dicom_core::value::InMemFragment>, start: u64) -> bool {
    let start = usize::try_from(start).unwrap_or(usize::MAX);
    match value {
        Value::Primitive(PrimitiveValue::U16(words)) => words.iter().skip(start / 2).all(|w| *w == 0),
        Value::Primitive(PrimitiveValue::I16(words)) => words.iter().skip(start / 2).all(|w| *w == 0),
        Value::Primitive(PrimitiveValue::U8(bytes)) => bytes.iter().skip(start).all(|b| *b == 0),
        _ => true,
    }
}

/// One frame of encapsulated PixelData, decoded by the registry's decoder for the file's
/// transfer syntax, or a 12-bit lossy JPEG one by [`jpeg12`]; a decoder that panics on a
/// hostile stream gives an error. Returns the frame's native bytes (little-endian samples) and
/// the decoder's harmless warning, if it gave one.
fn decode_frame(
    object: &DefaultDicomObject,
    frame: u32,
    header: &SliceHeader,
    path: &Path,
) -> Result<(Vec<u8>, Option<String>), VolumeError> {
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
    let declared = check_declared_size(object, frame, header, path)?;
    let cannot_decode = |problem: String| VolumeError::Dicom {
        problem: format!("frame {} of the {} PixelData cannot be decoded ({problem})", frame + 1, syntax.name()),
        path: path.to_path_buf(),
    };
    if JPEG_DCT_SYNTAXES.contains(&uid.trim_end_matches(['\0', ' ']))
        && declared.is_some_and(|d| d.precision == Some(12))
    {
        let codestream = frame_codestream(object, frame, header.frames_in_file)
            .ok_or_else(|| cannot_decode("its fragments cannot be told apart from the next frame's".into()))?;
        let decoded = jpeg12::decode(&codestream, header.columns, header.rows).map_err(cannot_decode)?;
        let bytes = decoded.samples.iter().flat_map(|sample| sample.to_le_bytes()).collect();
        return Ok((bytes, decoded.warning));
    }
    let mut bytes = Vec::new();
    let decoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        decoder.decode_frame(object, frame, &mut bytes).map_err(|error| error.to_string())
    }));
    match decoded {
        Ok(Ok(())) => Ok((bytes, None)),
        Ok(Err(problem)) => Err(cannot_decode(problem)),
        Err(_) => Err(VolumeError::Dicom {
            problem: format!("the {} decoder failed inside on frame {}", syntax.name(), frame + 1),
            path: path.to_path_buf(),
        }),
    }
}

/// JPEG Baseline (process 1) and Extended (processes 2 and 4): DCT-based JPEG.
const JPEG_DCT_SYNTAXES: [&str; 2] = ["1.2.840.10008.1.2.4.50", "1.2.840.10008.1.2.4.51"];

/// The whole codestream of `frame`: its one fragment, every fragment of a single-frame file,
/// or the fragments from the frame's basic offset table entry to the next frame's. `None` when
/// a multi-frame file with several fragments per frame has no usable offset table.
fn frame_codestream(object: &DefaultDicomObject, frame: u32, frames_in_file: u32) -> Option<Vec<u8>> {
    let Some(Value::PixelSequence(sequence)) = object.get(tags::PIXEL_DATA).map(|element| element.value()) else {
        return None;
    };
    let fragments = sequence.fragments();
    if fragments.len() == frames_in_file as usize {
        return fragments.get(frame as usize).cloned();
    }
    if frames_in_file == 1 {
        return Some(fragments.concat());
    }
    let offsets = sequence.offset_table();
    let start = u64::from(*offsets.get(frame as usize)?);
    let end = offsets.get(frame as usize + 1).map_or(u64::MAX, |end| u64::from(*end));
    let mut position = 0u64;
    let mut codestream = Vec::new();
    let mut started = false;
    for fragment in fragments {
        started |= position == start;
        if position >= end {
            break;
        }
        if started {
            codestream.extend_from_slice(fragment);
        }
        position += 8 + fragment.len() as u64;
    }
    started.then_some(codestream)
}

/// Refuses a compressed frame whose own header declares another size than Rows x Columns x 1
/// sample, before its decoder allocates what that header says ([`codestream`]); returns what it
/// declares, where it declares anything.
fn check_declared_size(
    object: &DefaultDicomObject,
    frame: u32,
    header: &SliceHeader,
    path: &Path,
) -> Result<Option<codestream::DeclaredSize>, VolumeError> {
    let Some(Value::PixelSequence(sequence)) = object.get(tags::PIXEL_DATA).map(|element| element.value()) else {
        return Ok(None);
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
        return Ok(None);
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
    Ok(Some(declared))
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

/// Masks, sign-extends and rescales stored samples, or maps them through the Modality LUT.
fn to_physical(stored: &[u16], format: PixelFormat, rescale: ValueScale, lut: Option<&ModalityLut>) -> DecodedSlice {
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
    if let Some(lut) = lut {
        let values: Vec<f32> = integers.iter().map(|&integer| lut.value(integer)).collect();
        let (min, max) =
            values.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(low, high), &v| (low.min(v), high.max(v)));
        let (min, max) = if values.is_empty() { (0.0, 0.0) } else { (min, max) };
        return DecodedSlice { values, min, max, note: None };
    }
    let ValueScale { slope, intercept } = rescale;
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
    DecodedSlice { values, min, max, note: None }
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
        let slice = to_physical(&stored, format(16, 16, true), ValueScale::IDENTITY, None);
        assert_eq!(slice.values, vec![0.0, 1.0, -1.0, -32768.0, 32767.0]);
        assert_eq!((slice.min, slice.max), (-32768.0, 32767.0));
    }

    #[test]
    fn twelve_bit_samples_ignore_the_high_bits_and_sign_extend_from_bit_11() {
        // 0xF000 are overlay bits in old CT files; 0x0800 is the sign bit of a 12-bit sample.
        let stored = [0xF001u16, 0x0FFF, 0x0800];
        let unsigned = to_physical(&stored, format(16, 12, false), ValueScale { slope: 1.0, intercept: -1024.0 }, None);
        assert_eq!(unsigned.values, vec![-1023.0, 3071.0, 1024.0]);
        let signed = to_physical(&stored, format(16, 12, true), ValueScale::IDENTITY, None);
        assert_eq!(signed.values, vec![1.0, -1.0, -2048.0]);
    }

    #[test]
    fn rescale_is_applied_after_decoding() {
        let slice = to_physical(&[10u16, 200], format(8, 8, false), ValueScale { slope: 0.5, intercept: -3.0 }, None);
        assert_eq!(slice.values, vec![2.0, 97.0]);
    }

    #[test]
    fn a_modality_lut_replaces_the_rescale_and_its_extremes_are_the_values_extremes() {
        // Not monotonic: the extremes come from the values, not from the extreme samples.
        let lut = ModalityLut { first_mapped: -2, entries: vec![50, 7, 900, 3] };
        let stored = [0xFFFEu16, 0xFFFF, 0, 1, 5, 0x8000];
        let slice = to_physical(&stored, format(16, 16, true), ValueScale::IDENTITY, Some(&lut));
        assert_eq!(slice.values, vec![50.0, 7.0, 900.0, 3.0, 3.0, 50.0]);
        assert_eq!((slice.min, slice.max), (3.0, 900.0));
    }
}
