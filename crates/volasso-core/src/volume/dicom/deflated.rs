//! Deflated Explicit VR Little Endian files (PS3.5 §A.5): the data set after the file meta
//! group is one raw deflate stream (RFC 1951). It is inflated here, bounded by the decode
//! ceiling and by what deflate can expand to, and the file is rebuilt as Explicit VR Little
//! Endian (the same meta group naming 1.2.840.10008.1.2.1, then the inflated data set), so
//! that [`super::bounds`] checks every byte dicom-object then parses, as for any other file.
//!
//! Entry point: [`inflate_file`], which the bounds check calls for a file whose meta group
//! names the deflated syntax.
//!
//! Never: trusts the compressed size to bound the inflated one, or hands on a byte it did not
//! inflate completely.

use crate::volume::VolumeError;
use crate::volume::limits::{self, ReadLimits};
use std::path::Path;

/// Deflated Explicit VR Little Endian.
pub(super) const DEFLATED_EXPLICIT_LITTLE: &str = "1.2.840.10008.1.2.1.99";
/// What the rebuilt file's meta group names instead (even length, padded with NUL).
const EXPLICIT_LITTLE_PADDED: &[u8; 20] = b"1.2.840.10008.1.2.1\0";

/// The meta group of a file: its elements after the group length, as (tag element, start,
/// end) byte ranges, and where the data set starts.
#[derive(Debug, PartialEq, Eq)]
pub(super) struct MetaLayout {
    /// Byte ranges of each element after (0002,0000), with its element number.
    pub elements: Vec<(u16, usize, usize)>,
    pub data_set_start: usize,
}

/// `bytes` (a whole file whose meta group is `meta`) with its data set inflated and its meta
/// group naming Explicit VR Little Endian; errors name the ceiling or the corrupt stream.
pub(super) fn inflate_file(
    bytes: &[u8],
    meta: &MetaLayout,
    limits: &ReadLimits,
    path: &Path,
) -> Result<Vec<u8>, VolumeError> {
    let compressed = bytes.get(meta.data_set_start..).unwrap_or_default();
    let most = (compressed.len() as u64).saturating_mul(limits::DEFLATE_MOST_EXPANSION);
    let ceiling = limits.max_decoded_bytes.min(most);
    let mut group = Vec::new();
    for &(element, start, end) in &meta.elements {
        if element == 0x0010 {
            group.extend([0x02, 0x00, 0x10, 0x00, b'U', b'I']);
            group.extend((EXPLICIT_LITTLE_PADDED.len() as u16).to_le_bytes());
            group.extend(EXPLICIT_LITTLE_PADDED);
        } else {
            group.extend(&bytes[start..end]);
        }
    }
    let mut rebuilt = limits::reserve(132 + 12 + group.len(), path)?;
    rebuilt.extend(&bytes[..132]);
    rebuilt.extend([0x02, 0x00, 0x00, 0x00, b'U', b'L', 4, 0]);
    rebuilt.extend((group.len() as u32).to_le_bytes());
    rebuilt.extend(group);
    let mut decoder = flate2::read::DeflateDecoder::new(compressed);
    let inflated_start = rebuilt.len();
    let read = std::io::Read::read_to_end(&mut std::io::Read::take(&mut decoder, ceiling + 1), &mut rebuilt)
        .map_err(|source| VolumeError::Decompress { source, path: path.to_path_buf() })?;
    if read as u64 > ceiling {
        limits::check_ceiling(read as u64, limits, path)?;
        return Err(VolumeError::Dicom {
            problem: format!(
                "the deflated data set inflates beyond {most} bytes, more than its {} compressed bytes can hold",
                compressed.len()
            ),
            path: path.to_path_buf(),
        });
    }
    if rebuilt.len() == inflated_start {
        return Err(VolumeError::Dicom { problem: "the deflated data set is empty".into(), path: path.to_path_buf() });
    }
    Ok(rebuilt)
}

#[cfg(test)]
mod tests {
    use super::super::bounds::{Scope, read_object};
    use super::*;
    use dicom_dictionary_std::tags;

    const PHILIPS_SLICE: &str =
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/dicom/philips_phantom_5mm/I10");

    /// The Philips slice as Deflated Explicit VR Little Endian, written by dicom-object.
    fn deflated_copy(folder: &Path) -> std::path::PathBuf {
        let object = dicom_object::OpenFileOptions::new().open_file(PHILIPS_SLICE).unwrap();
        let mut meta = object.meta().clone();
        meta.transfer_syntax = DEFLATED_EXPLICIT_LITTLE.to_string();
        let path = folder.join("deflated.dcm");
        let bytes = deflate_body(&object, &meta);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    /// Preamble, meta group, then the data set as explicit VR little endian, deflated.
    fn deflate_body(object: &dicom_object::DefaultDicomObject, meta: &dicom_object::FileMetaTable) -> Vec<u8> {
        let mut bytes = vec![0u8; 128];
        bytes.extend(b"DICM");
        meta.write(&mut bytes).unwrap();
        let mut data_set = Vec::new();
        let explicit = dicom_transfer_syntax_registry::entries::EXPLICIT_VR_LITTLE_ENDIAN.erased();
        object.write_dataset_with_ts(&mut data_set, &explicit).unwrap();
        let mut encoder = flate2::write::DeflateEncoder::new(bytes, flate2::Compression::default());
        std::io::Write::write_all(&mut encoder, &data_set).unwrap();
        encoder.finish().unwrap()
    }

    #[test]
    fn a_deflated_file_reads_as_its_uncompressed_original() {
        let folder = tempfile::tempdir().unwrap();
        let path = deflated_copy(folder.path());
        assert!(std::fs::metadata(&path).unwrap().len() < std::fs::metadata(PHILIPS_SLICE).unwrap().len());
        let limits = ReadLimits::default();
        let deflated = read_object(&path, Scope::Whole, &limits).unwrap();
        let original = read_object(Path::new(PHILIPS_SLICE), Scope::Whole, &limits).unwrap();
        let pixels = |object: &dicom_object::DefaultDicomObject| {
            object.get(tags::PIXEL_DATA).unwrap().to_bytes().unwrap().to_vec()
        };
        assert_eq!(pixels(&deflated), pixels(&original));
        let header = read_object(&path, Scope::Header, &limits).unwrap();
        assert!(header.get(tags::ROWS).is_some() && header.get(tags::PIXEL_DATA).is_none());
    }

    #[test]
    fn a_deflate_bomb_stops_at_the_ceiling_and_a_corrupt_stream_is_an_error() {
        let folder = tempfile::tempdir().unwrap();
        let path = deflated_copy(folder.path());
        let limits = ReadLimits { max_decoded_bytes: 100_000, ..ReadLimits::default() };
        let error = read_object(&path, Scope::Whole, &limits).unwrap_err().to_string();
        assert!(error.contains("100000"), "{error}");
        let mut bytes = std::fs::read(&path).unwrap();
        let cut = bytes.len() / 2;
        bytes.truncate(cut);
        std::fs::write(&path, &bytes).unwrap();
        assert!(read_object(&path, Scope::Whole, &ReadLimits::default()).is_err());
    }
}
