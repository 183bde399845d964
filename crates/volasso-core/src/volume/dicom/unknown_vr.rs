//! Elements stored with VR UN (unknown) whose tag the standard dictionary knows get the
//! dictionary's VR, their bytes read again in it, as pydicom and dcmtk do. A file that passed
//! through a system which did not know an attribute (an old archive, an anonymiser, a
//! converter writing explicit VR from implicit) may carry RescaleSlope, PixelSpacing,
//! ImagePositionPatient or SeriesInstanceUID as UN; read as bytes, a rescale would be refused
//! or, worse, a series split by UIDs that are not its UIDs.
//!
//! [`read_object`] is [`super::bounds::read_object`] followed by this, for the data set and the
//! items of its sequences.
//!
//! Never: touches private elements, tags the dictionary does not know, or UN elements whose
//! dictionary VR is a sequence, binary (OB, OW, ...) or ambiguous (US or SS): those keep
//! their bytes.

use super::bounds::{self, Scope};
use crate::volume::VolumeError;
use crate::volume::limits::ReadLimits;
use dicom_core::dictionary::{DataDictionary, DataDictionaryEntry, VirtualVr};
use dicom_core::header::Header;
use dicom_core::value::{C, PrimitiveValue, Value};
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::StandardDataDictionary;
use dicom_object::{DefaultDicomObject, InMemDicomObject};
use std::path::Path;

/// Explicit VR Big Endian: numbers in UN elements are big-endian there.
const EXPLICIT_BIG: &str = "1.2.840.10008.1.2.2";

/// Reads `path` as [`bounds::read_object`] does, then gives known UN elements their VR.
pub(super) fn read_object(path: &Path, scope: Scope, limits: &ReadLimits) -> Result<DefaultDicomObject, VolumeError> {
    let mut object = bounds::read_object(path, scope, limits)?;
    let big_endian = object.meta().transfer_syntax().trim_end_matches(['\0', ' ']) == EXPLICIT_BIG;
    resolve(&mut object, big_endian);
    Ok(object)
}

/// Gives every known UN element of `object` and of its sequences' items the dictionary's VR.
/// The nesting is bounded by [`bounds`]' walk, which refuses deeper files.
pub(super) fn resolve(object: &mut InMemDicomObject, big_endian: bool) {
    let elements: Vec<(Tag, VR)> = object.iter().map(|element| (element.tag(), element.vr())).collect();
    for (tag, vr) in elements {
        if vr == VR::SQ {
            object.update_value(tag, |value| {
                if let Some(items) = value.items_mut() {
                    items.iter_mut().for_each(|item| resolve(item, big_endian));
                }
            });
            continue;
        }
        if vr != VR::UN || tag.group() % 2 == 1 {
            continue;
        }
        let Some(VirtualVr::Exact(known)) = StandardDataDictionary.by_tag(tag).map(|entry| entry.vr()) else {
            continue;
        };
        let Some(Value::Primitive(PrimitiveValue::U8(bytes))) = object.get(tag).map(|element| element.value()) else {
            continue;
        };
        if let Some(value) = reinterpret(known, bytes, big_endian) {
            object.put(DataElement::new(tag, known, value));
        }
    }
}

/// The value of `bytes` read as `vr`; `None` for VRs left as bytes, or bytes that do not fit
/// the VR (a length that is not a multiple of a number's size).
fn reinterpret(vr: VR, bytes: &[u8], big_endian: bool) -> Option<PrimitiveValue> {
    match vr {
        VR::AE
        | VR::AS
        | VR::CS
        | VR::DA
        | VR::DS
        | VR::DT
        | VR::IS
        | VR::LO
        | VR::PN
        | VR::SH
        | VR::TM
        | VR::UC
        | VR::UI => Some(PrimitiveValue::Strs(text(bytes).split('\\').map(trimmed).collect())),
        VR::LT | VR::ST | VR::UT | VR::UR => Some(PrimitiveValue::Str(trimmed(&text(bytes)))),
        VR::US => numbers::<2, u16>(bytes, big_endian, u16::from_le_bytes, u16::from_be_bytes).map(PrimitiveValue::U16),
        VR::SS => numbers::<2, i16>(bytes, big_endian, i16::from_le_bytes, i16::from_be_bytes).map(PrimitiveValue::I16),
        VR::UL => numbers::<4, u32>(bytes, big_endian, u32::from_le_bytes, u32::from_be_bytes).map(PrimitiveValue::U32),
        VR::SL => numbers::<4, i32>(bytes, big_endian, i32::from_le_bytes, i32::from_be_bytes).map(PrimitiveValue::I32),
        VR::FL => numbers::<4, f32>(bytes, big_endian, f32::from_le_bytes, f32::from_be_bytes).map(PrimitiveValue::F32),
        VR::FD => numbers::<8, f64>(bytes, big_endian, f64::from_le_bytes, f64::from_be_bytes).map(PrimitiveValue::F64),
        _ => None,
    }
}

/// Text as UTF-8 where it is valid (ASCII always is), else byte by byte as ISO 8859-1, the
/// most common DICOM character set after ASCII.
fn text(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(text) => text.to_string(),
        Err(_) => bytes.iter().map(|&byte| char::from(byte)).collect(),
    }
}

/// One value without the space and NUL padding DICOM puts around it.
fn trimmed(value: &str) -> String {
    value.trim_matches([' ', '\0']).to_string()
}

fn numbers<const N: usize, T>(
    bytes: &[u8],
    big_endian: bool,
    little: fn([u8; N]) -> T,
    big: fn([u8; N]) -> T,
) -> Option<C<T>> {
    if bytes.len() % N != 0 {
        return None;
    }
    let read = if big_endian { big } else { little };
    Some(bytes.chunks_exact(N).map(|chunk| read(chunk.try_into().unwrap_or([0; N]))).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use dicom_dictionary_std::tags;

    fn un(tag: Tag, bytes: &[u8]) -> DataElement<InMemDicomObject> {
        DataElement::new(tag, VR::UN, PrimitiveValue::U8(bytes.iter().copied().collect()))
    }

    #[test]
    fn known_un_elements_take_the_dictionary_vr_and_others_keep_their_bytes() {
        let mut object = InMemDicomObject::from_element_iter([
            un(tags::RESCALE_SLOPE, b"2.5 "),
            un(tags::PIXEL_SPACING, b"0.5\\0.75"),
            un(tags::SERIES_INSTANCE_UID, b"1.2.3\0"),
            un(tags::ROWS, &[0x00, 0x02]),
            un(tags::SERIES_DESCRIPTION, b"K\xf6rper"),
            un(Tag(0x0009, 0x1010), b"1.5 "),
            un(tags::PIXEL_DATA, &[1, 2]),
        ]);
        resolve(&mut object, false);
        let get = |tag| object.get(tag).unwrap();
        assert_eq!((get(tags::RESCALE_SLOPE).vr(), get(tags::RESCALE_SLOPE).to_float64().unwrap()), (VR::DS, 2.5));
        assert_eq!(get(tags::PIXEL_SPACING).to_multi_float64().unwrap(), vec![0.5, 0.75]);
        assert_eq!(get(tags::SERIES_INSTANCE_UID).to_str().unwrap(), "1.2.3");
        assert_eq!(get(tags::ROWS).to_int::<u16>().unwrap(), 512);
        assert_eq!(get(tags::SERIES_DESCRIPTION).to_str().unwrap(), "Körper");
        assert_eq!(get(Tag(0x0009, 0x1010)).vr(), VR::UN);
        assert_eq!(get(tags::PIXEL_DATA).vr(), VR::UN);

        let mut big = InMemDicomObject::from_element_iter([un(tags::ROWS, &[0x02, 0x00]), un(tags::COLUMNS, &[1])]);
        resolve(&mut big, true);
        assert_eq!(big.get(tags::ROWS).unwrap().to_int::<u16>().unwrap(), 512);
        assert_eq!(big.get(tags::COLUMNS).unwrap().vr(), VR::UN, "one byte is no US");
    }

    #[test]
    fn un_elements_inside_sequence_items_are_resolved() {
        let item = InMemDicomObject::from_element_iter([un(tags::RESCALE_INTERCEPT, b"-1024")]);
        let mut object = InMemDicomObject::from_element_iter([DataElement::new(
            tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
            VR::SQ,
            dicom_core::value::DataSetSequence::from(vec![item]),
        )]);
        resolve(&mut object, false);
        let items = object.get(tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE).unwrap().items().unwrap();
        assert_eq!(items[0].get(tags::RESCALE_INTERCEPT).unwrap().to_float64().unwrap(), -1024.0);
    }
}
