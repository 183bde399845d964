//! JPEG 2000 (lossless, 1.2.840.10008.1.2.4.90) DICOM reads to the voxels of the uncompressed
//! series. dcmtk has no JPEG 2000 encoder, so each Philips slice is compressed here with
//! OpenJPEG itself (the `openjpeg-sys` the reader decodes with: reversible 5/3 wavelet, one
//! quality layer, 12-bit unsigned samples as BitsStored says) and wrapped as encapsulated
//! PixelData with dicom-object.
//!
//! Never: changes anything but the pixel encoding and the transfer syntax.

use crate::dicom_codecs::{assert_same_volume, philips_files};
use dicom_core::value::PixelFragmentSequence;
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
use openjpeg_sys as opj;
use std::ffi::c_void;
use std::path::Path;

const JPEG_2000_LOSSLESS: &str = "1.2.840.10008.1.2.4.90";

/// The output stream's bytes and write position (OpenJPEG may seek back while writing).
struct Sink {
    bytes: Vec<u8>,
    position: usize,
}

unsafe extern "C" fn write(buffer: *mut c_void, count: usize, user: *mut c_void) -> usize {
    // SAFETY: OpenJPEG passes back the Sink given to opj_stream_set_user_data and a buffer of
    // `count` bytes.
    let (sink, data) = unsafe { (&mut *(user as *mut Sink), std::slice::from_raw_parts(buffer as *const u8, count)) };
    let end = sink.position + count;
    if sink.bytes.len() < end {
        sink.bytes.resize(end, 0);
    }
    sink.bytes[sink.position..end].copy_from_slice(data);
    sink.position = end;
    count
}

unsafe extern "C" fn skip(count: i64, user: *mut c_void) -> i64 {
    // SAFETY: as in `write`.
    let sink = unsafe { &mut *(user as *mut Sink) };
    sink.position = (sink.position as i64 + count).max(0) as usize;
    count
}

unsafe extern "C" fn seek(position: i64, user: *mut c_void) -> i32 {
    // SAFETY: as in `write`.
    let sink = unsafe { &mut *(user as *mut Sink) };
    sink.position = position.max(0) as usize;
    1
}

/// A lossless JPEG 2000 codestream of one `width` x `height` plane of `bits`-bit unsigned samples.
fn encode_lossless(samples: &[u16], width: u32, height: u32, bits: u32) -> Vec<u8> {
    assert_eq!(samples.len(), (width * height) as usize);
    let mut sink = Sink { bytes: Vec::new(), position: 0 };
    // SAFETY: the OpenJPEG encoding sequence of its own opj_compress tool: every pointer is
    // checked, the image's one component holds width x height samples, and everything created
    // is destroyed before `sink` is read.
    unsafe {
        let mut component = opj::opj_image_cmptparm_t {
            dx: 1,
            dy: 1,
            w: width,
            h: height,
            x0: 0,
            y0: 0,
            prec: bits,
            bpp: bits,
            sgnd: 0,
        };
        let image = opj::opj_image_create(1, &mut component, opj::OPJ_COLOR_SPACE::OPJ_CLRSPC_GRAY);
        assert!(!image.is_null());
        (*image).x1 = width;
        (*image).y1 = height;
        let data = std::slice::from_raw_parts_mut((*(*image).comps).data, samples.len());
        for (target, &sample) in data.iter_mut().zip(samples) {
            *target = i32::from(sample);
        }
        let mut parameters = std::mem::zeroed::<opj::opj_cparameters_t>();
        opj::opj_set_default_encoder_parameters(&mut parameters);
        parameters.tcp_numlayers = 1;
        parameters.tcp_rates[0] = 0.0; // no rate limit: lossless with the reversible wavelet
        parameters.cp_disto_alloc = 1;
        parameters.irreversible = 0;
        let codec = opj::opj_create_compress(opj::OPJ_CODEC_FORMAT::OPJ_CODEC_J2K);
        assert!(!codec.is_null());
        assert_eq!(opj::opj_setup_encoder(codec, &mut parameters, image), 1);
        let stream = opj::opj_stream_create(1 << 16, 0);
        assert!(!stream.is_null());
        opj::opj_stream_set_user_data(stream, &mut sink as *mut Sink as *mut c_void, None);
        opj::opj_stream_set_write_function(stream, Some(write));
        opj::opj_stream_set_skip_function(stream, Some(skip));
        opj::opj_stream_set_seek_function(stream, Some(seek));
        let encoded = opj::opj_start_compress(codec, image, stream) == 1
            && opj::opj_encode(codec, stream) == 1
            && opj::opj_end_compress(codec, stream) == 1;
        opj::opj_stream_destroy(stream);
        opj::opj_destroy_codec(codec);
        opj::opj_image_destroy(image);
        assert!(encoded, "OpenJPEG failed to encode");
    }
    sink.bytes
}

/// Writes `file` (a Philips slice) to `out` as JPEG 2000 lossless DICOM, its codestream passed
/// through `edit` first; the codestream's length.
fn write_jpeg2000_copy(file: &Path, out: &Path, edit: impl Fn(&mut Vec<u8>)) -> usize {
    let object = dicom_object::open_file(file).unwrap();
    let (sop_class, sop_instance) = (
        object.element(tags::SOP_CLASS_UID).unwrap().to_str().unwrap().to_string(),
        object.element(tags::SOP_INSTANCE_UID).unwrap().to_str().unwrap().to_string(),
    );
    let number = |tag| object.element(tag).unwrap().to_int::<u32>().unwrap();
    let (rows, columns, bits_stored) = (number(tags::ROWS), number(tags::COLUMNS), number(tags::BITS_STORED));
    assert_eq!((number(tags::BITS_ALLOCATED), number(tags::PIXEL_REPRESENTATION)), (16, 0));
    let raw = object.element(tags::PIXEL_DATA).unwrap().to_bytes().unwrap();
    // The stored bits only, as a JPEG 2000 encoder of BitsStored-bit samples sees them (the
    // reader masks the unused high bits of native data the same way).
    let samples: Vec<u16> =
        raw.chunks_exact(2).map(|pair| u16::from_le_bytes([pair[0], pair[1]]) & ((1 << bits_stored) - 1)).collect();
    let mut codestream = encode_lossless(&samples, columns, rows, bits_stored);
    assert_eq!(&codestream[..4], [0xFF, 0x4F, 0xFF, 0x51], "a J2K codestream starts SOC, SIZ");
    edit(&mut codestream);
    if codestream.len() % 2 == 1 {
        codestream.push(0); // fragments have even length
    }
    let length = codestream.len();
    let mut dataset = object.into_inner();
    dataset.put(DataElement::<InMemDicomObject>::new(
        tags::PIXEL_DATA,
        VR::OB,
        PixelFragmentSequence::new(vec![0u32], vec![codestream]),
    ));
    dataset
        .with_meta(
            FileMetaTableBuilder::new()
                .transfer_syntax(JPEG_2000_LOSSLESS)
                .media_storage_sop_class_uid(sop_class)
                .media_storage_sop_instance_uid(sop_instance),
        )
        .unwrap()
        .write_to_file(out)
        .unwrap();
    length
}

#[test]
fn jpeg_2000_lossless_copies_read_to_the_uncompressed_voxels() {
    let root = tempfile::tempdir().unwrap();
    let folder = root.path().join("jpeg-2000-lossless");
    std::fs::create_dir(&folder).unwrap();
    let compressed_bytes: usize = philips_files()
        .iter()
        .map(|file| write_jpeg2000_copy(file, &folder.join(file.file_name().unwrap()), |_| ()))
        .sum();
    // Really compressed: the native series is 28 x 512 x 512 x 2 bytes.
    assert!(compressed_bytes < 28 * 512 * 512 * 2 / 2, "{compressed_bytes} bytes");
    assert_same_volume(&folder, "JPEG 2000 lossless (OpenJPEG)");
}

#[test]
fn a_jpeg_2000_frame_that_declares_another_size_is_refused_before_decoding() {
    let root = tempfile::tempdir().unwrap();
    let lying = root.path().join("lying.dcm");
    // SIZ after SOC: marker (2), Lsiz (2), Rsiz (2), then Xsiz and Ysiz (4 bytes each).
    write_jpeg2000_copy(&philips_files()[0], &lying, |codestream| {
        codestream[8..16].copy_from_slice(&[0, 0, 0xFF, 0xFF, 0, 0, 0xFF, 0xFF]);
    });
    let output = crate::support::volasso(&["info", lying.to_str().unwrap()], &root.path().join("cache"));
    crate::support::assert_clean_error(&output, "compressed as 65535 x 65535 pixels", "a lying JPEG 2000 SIZ");
}
