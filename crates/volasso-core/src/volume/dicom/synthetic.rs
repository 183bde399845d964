//! Test support: writes small DICOM CT slices with known geometry and values (dicom-object).

use dicom_core::value::{C, PrimitiveValue};
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};
use std::path::Path;

pub(super) const EXPLICIT_LITTLE: &str = "1.2.840.10008.1.2.1";
pub(super) const IMPLICIT_LITTLE: &str = "1.2.840.10008.1.2";
const AXIAL: [f64; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// One synthetic CT slice; `stored` is row by row, `columns` values per row.
#[derive(Clone)]
pub(super) struct SyntheticSlice {
    pub series_uid: String,
    pub sop_uid: String,
    pub columns: usize,
    pub rows: usize,
    /// DICOM order: between rows, between columns.
    pub pixel_spacing_mm: [f64; 2],
    pub position_mm: Option<[f64; 3]>,
    pub orientation: [f64; 6],
    pub stored: Vec<i16>,
    pub slope: f64,
    pub intercept: f64,
    pub samples_per_pixel: u16,
    pub with_pixel_data: bool,
    pub transfer_syntax: &'static str,
}

impl SyntheticSlice {
    /// An axial slice whose stored value at (column, row) is `value(column, row)`.
    pub fn axial(
        series_uid: &str,
        sop_uid: &str,
        [columns, rows]: [usize; 2],
        position_mm: [f64; 3],
        value: impl Fn(usize, usize) -> i16,
    ) -> SyntheticSlice {
        let stored = (0..rows)
            .flat_map(|row| (0..columns).map(move |column| (column, row)))
            .map(|(column, row)| value(column, row))
            .collect();
        SyntheticSlice {
            series_uid: series_uid.into(),
            sop_uid: sop_uid.into(),
            columns,
            rows,
            pixel_spacing_mm: [1.0, 1.0],
            position_mm: Some(position_mm),
            orientation: AXIAL,
            stored,
            slope: 1.0,
            intercept: 0.0,
            samples_per_pixel: 1,
            with_pixel_data: true,
            transfer_syntax: EXPLICIT_LITTLE,
        }
    }

    pub fn write(&self, path: &Path) {
        let ds = |values: &[f64]| PrimitiveValue::Strs(values.iter().map(|v| v.to_string()).collect::<C<String>>());
        let us = |value: u16| PrimitiveValue::U16(C::from_elem(value, 1));
        let mut elements = vec![
            DataElement::new(tags::SOP_CLASS_UID, VR::UI, "1.2.840.10008.5.1.4.1.1.2"),
            DataElement::new(tags::SOP_INSTANCE_UID, VR::UI, self.sop_uid.as_str()),
            DataElement::new(tags::MODALITY, VR::CS, "CT"),
            DataElement::new(tags::SERIES_DESCRIPTION, VR::LO, "synthetic"),
            DataElement::new(tags::SERIES_INSTANCE_UID, VR::UI, self.series_uid.as_str()),
            DataElement::new(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, ds(&self.orientation)),
            DataElement::new(tags::SAMPLES_PER_PIXEL, VR::US, us(self.samples_per_pixel)),
            DataElement::new(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, "MONOCHROME2"),
            DataElement::new(tags::ROWS, VR::US, us(self.rows as u16)),
            DataElement::new(tags::COLUMNS, VR::US, us(self.columns as u16)),
            DataElement::new(tags::PIXEL_SPACING, VR::DS, ds(&self.pixel_spacing_mm)),
            DataElement::new(tags::BITS_ALLOCATED, VR::US, us(16)),
            DataElement::new(tags::BITS_STORED, VR::US, us(16)),
            DataElement::new(tags::HIGH_BIT, VR::US, us(15)),
            DataElement::new(tags::PIXEL_REPRESENTATION, VR::US, us(1)),
            DataElement::new(tags::RESCALE_INTERCEPT, VR::DS, ds(&[self.intercept])),
            DataElement::new(tags::RESCALE_SLOPE, VR::DS, ds(&[self.slope])),
        ];
        if let Some(position) = self.position_mm {
            elements.push(DataElement::new(tags::IMAGE_POSITION_PATIENT, VR::DS, ds(&position)));
        }
        if self.with_pixel_data {
            let words: C<u16> = self.stored.iter().map(|v| *v as u16).collect();
            elements.push(DataElement::new(tags::PIXEL_DATA, VR::OW, PrimitiveValue::U16(words)));
        }
        InMemDicomObject::from_element_iter(elements)
            .with_meta(FileMetaTableBuilder::new().transfer_syntax(self.transfer_syntax))
            .unwrap()
            .write_to_file(path)
            .unwrap();
    }
}
