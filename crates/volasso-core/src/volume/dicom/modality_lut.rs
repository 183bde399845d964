//! The Modality LUT (PS3.3 C.11.1): a table in place of RescaleSlope and RescaleIntercept that
//! maps stored values to the values a viewer shows (OD, Hounsfield units, or unspecified).
//!
//! [`ModalityLut::read`] reads the file's ModalityLUTSequence, and [`ModalityLut::value`] maps
//! a stored value as pydicom's `apply_modality_lut` does: values below the first mapped value
//! take the first entry, values past the table the last. The LUT Descriptor's first value is the
//! number of entries (0 meaning 65536), its second the first stored value mapped (signed when
//! PixelRepresentation is, whatever VR an implicit-VR reading gave it), its third the bits of
//! each entry (8 or 16); LUT Data holds exactly that many entries.
//!
//! Never: ignores a Modality LUT Sequence. One it cannot apply (several items, a descriptor or
//! data out of the standard, a rescale beside it) is an error naming what is wrong.

use crate::volume::{ValueScale, VolumeError};
use dicom_core::VR;
use dicom_core::value::{PrimitiveValue, Value};
use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;
use std::path::Path;
use std::sync::Arc;

/// A Modality LUT: `entries[0]` is the value of stored value `first_mapped`.
#[derive(Debug, PartialEq)]
pub(super) struct ModalityLut {
    pub first_mapped: i32,
    pub entries: Vec<u16>,
}

impl ModalityLut {
    /// The LUT of `object`'s ModalityLUTSequence, `None` when it has none (or an empty one, as
    /// pydicom reads it). `signed` is PixelRepresentation 1; `rescale` is the file's RescaleSlope
    /// and RescaleIntercept, which must then be absent (identity).
    pub fn read(
        object: &InMemDicomObject,
        signed: bool,
        rescale: ValueScale,
        path: &Path,
    ) -> Result<Option<Arc<ModalityLut>>, VolumeError> {
        let Some(element) = object.get(tags::MODALITY_LUT_SEQUENCE) else { return Ok(None) };
        let invalid = |problem: String| VolumeError::header("ModalityLUTSequence", problem, path);
        let items = element.items().ok_or_else(|| invalid(format!("is {}, not a sequence", element.vr())))?;
        let item = match items {
            [] => return Ok(None),
            [item] => item,
            _ => return Err(invalid(format!("has {} items; the standard allows one", items.len()))),
        };
        if !rescale.is_identity() {
            return Err(invalid(format!(
                "is present beside RescaleSlope {} and RescaleIntercept {}: the file does not say which maps its values",
                rescale.slope, rescale.intercept
            )));
        }
        let descriptor =
            item.get(tags::LUT_DESCRIPTOR).ok_or_else(|| invalid("its item has no LUTDescriptor".into()))?;
        let values = descriptor
            .to_multi_int::<i32>()
            .map_err(|error| invalid(format!("LUTDescriptor is unreadable ({error})")))?;
        let [count, first, bits] = values.as_slice() else {
            return Err(invalid(format!("LUTDescriptor has {} values, not 3", values.len())));
        };
        // Each value is 16 bits, US or SS; only the first mapped value is ever negative.
        let count = match *count & 0xFFFF {
            0 => 65536,
            count => count as usize,
        };
        let first_mapped = if signed { i32::from((*first & 0xFFFF) as u16 as i16) } else { *first & 0xFFFF };
        if *bits != 8 && *bits != 16 {
            return Err(invalid(format!("LUTDescriptor gives entries of {bits} bits; 8 and 16 are defined")));
        }
        let data = item.get(tags::LUT_DATA).ok_or_else(|| invalid("its item has no LUTData".into()))?;
        let entries: Vec<u16> = match data.value() {
            Value::Primitive(PrimitiveValue::U16(words)) => words.to_vec(),
            Value::Primitive(PrimitiveValue::I16(words)) => words.iter().map(|word| *word as u16).collect(),
            _ if data.vr() == VR::UN => return Err(invalid("LUTData is stored as UN (unknown VR)".into())),
            _ => return Err(invalid(format!("LUTData is {}, not US or OW", data.vr()))),
        };
        if entries.len() != count {
            return Err(invalid(format!("LUTData holds {} entries; LUTDescriptor says {count}", entries.len())));
        }
        if *bits == 8
            && let Some(large) = entries.iter().find(|entry| **entry > 255)
        {
            return Err(invalid(format!("an 8-bit LUT entry is {large}")));
        }
        Ok(Some(Arc::new(ModalityLut { first_mapped, entries })))
    }

    /// The value a viewer shows for stored value `stored`.
    pub fn value(&self, stored: i32) -> f32 {
        let last = self.entries.len() as i64 - 1;
        let index = (i64::from(stored) - i64::from(self.first_mapped)).clamp(0, last);
        f32::from(self.entries[index as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dicom_core::DataElement;
    use dicom_core::value::{C, DataSetSequence};

    fn with_lut(descriptor: PrimitiveValue, data: PrimitiveValue) -> InMemDicomObject {
        let item = InMemDicomObject::from_element_iter([
            DataElement::new(tags::LUT_DESCRIPTOR, VR::US, descriptor),
            DataElement::new(tags::LUT_DATA, VR::OW, data),
        ]);
        InMemDicomObject::from_element_iter([DataElement::new(
            tags::MODALITY_LUT_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(vec![item]),
        )])
    }

    fn read(object: &InMemDicomObject, signed: bool) -> Result<Option<Arc<ModalityLut>>, VolumeError> {
        ModalityLut::read(object, signed, ValueScale::IDENTITY, Path::new("lut.dcm"))
    }

    #[test]
    fn stored_values_are_clipped_to_the_table_and_mapped_through_it() {
        let object =
            with_lut(PrimitiveValue::U16(C::from(vec![3, 10, 16])), PrimitiveValue::U16(C::from(vec![7, 500, 65535])));
        let lut = read(&object, false).unwrap().unwrap();
        let values: Vec<f32> = [0, 9, 10, 11, 12, 13, 4000].into_iter().map(|stored| lut.value(stored)).collect();
        assert_eq!(values, [7.0, 7.0, 7.0, 500.0, 65535.0, 65535.0, 65535.0]);
    }

    #[test]
    fn the_first_mapped_value_is_signed_for_signed_pixels_whatever_its_vr() {
        // -2048 read as US from an implicit-VR file is 63488.
        let object =
            with_lut(PrimitiveValue::U16(C::from(vec![2, 63488, 16])), PrimitiveValue::U16(C::from(vec![1, 2])));
        assert_eq!(read(&object, true).unwrap().unwrap().first_mapped, -2048);
        assert_eq!(read(&object, false).unwrap().unwrap().first_mapped, 63488);
        let signed =
            with_lut(PrimitiveValue::I16(C::from(vec![2, -2048, 16])), PrimitiveValue::U16(C::from(vec![1, 2])));
        assert_eq!(read(&signed, true).unwrap().unwrap().first_mapped, -2048);
    }

    #[test]
    fn a_descriptor_of_zero_entries_means_65536() {
        let object =
            with_lut(PrimitiveValue::U16(C::from(vec![0, 0, 16])), PrimitiveValue::U16((0..=65535u16).collect()));
        let lut = read(&object, false).unwrap().unwrap();
        assert_eq!((lut.entries.len(), lut.value(65535)), (65536, 65535.0));
    }

    #[test]
    fn tables_it_cannot_apply_are_refused_with_the_reason() {
        let error = |object: InMemDicomObject| read(&object, false).unwrap_err().to_string();
        let short = with_lut(PrimitiveValue::U16(C::from(vec![4, 0, 16])), PrimitiveValue::U16(C::from(vec![1, 2])));
        assert!(error(short).contains("holds 2 entries; LUTDescriptor says 4"));
        let twelve = with_lut(PrimitiveValue::U16(C::from(vec![2, 0, 12])), PrimitiveValue::U16(C::from(vec![1, 2])));
        assert!(error(twelve).contains("12 bits"));
        let wide = with_lut(PrimitiveValue::U16(C::from(vec![2, 0, 8])), PrimitiveValue::U16(C::from(vec![1, 256])));
        assert!(error(wide).contains("8-bit LUT entry is 256"));
        let object = with_lut(PrimitiveValue::U16(C::from(vec![2, 0, 16])), PrimitiveValue::U16(C::from(vec![1, 2])));
        let both = ModalityLut::read(&object, false, ValueScale { slope: 1.0, intercept: -1024.0 }, Path::new("x"));
        assert!(both.unwrap_err().to_string().contains("beside RescaleSlope 1 and RescaleIntercept -1024"));
        assert_eq!(read(&InMemDicomObject::new_empty(), false).unwrap(), None);
    }
}
