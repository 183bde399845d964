//! A picture (the 3-D view) as a Secondary Capture image (PS3.3 A.8.1): 8-bit RGB, pixel
//! interleaved, in a new series of the source's study, its alpha composited over black as the
//! kiosk shows it.
//!
//! Never: claims a patient position or orientation for the picture (it is a rendering, not a
//! slice), or keeps an alpha channel.

use super::{
    ExportError, SECONDARY_CAPTURE_STORAGE, SourceSeries, copy_patient_and_study, date_time_now, new_uid,
    put_equipment, text, texts, ushort, with_meta,
};
use dicom_core::{DataElement, PrimitiveValue, VR};
use dicom_dictionary_std::tags;
use dicom_object::{FileDicomObject, InMemDicomObject};

/// The Secondary Capture of `picture` for the study of `source`.
pub fn secondary_capture(
    source: &SourceSeries,
    picture: &image::RgbaImage,
) -> Result<FileDicomObject<InMemDicomObject>, ExportError> {
    let (width, height) = picture.dimensions();
    let (Ok(rows), Ok(columns)) = (u16::try_from(height), u16::try_from(width)) else {
        return Err(ExportError::Build {
            what: "Secondary Capture",
            problem: format!("{width}x{height} pixels is more than DICOM's 65535 per side"),
        });
    };
    let mut pixels: Vec<u8> = Vec::with_capacity((width as usize * height as usize * 3).next_multiple_of(2));
    for pixel in picture.pixels() {
        let [r, g, b, a] = pixel.0;
        let over_black = |c: u8| ((u16::from(c) * u16::from(a) + 127) / 255) as u8;
        pixels.extend([over_black(r), over_black(g), over_black(b)]);
    }
    if pixels.len() % 2 == 1 {
        pixels.push(0);
    }
    let (date, time) = date_time_now();
    let series_number = source.text(tags::SERIES_NUMBER).trim().parse::<i64>().map_or(2000, |n| n + 2000);
    let mut object = InMemDicomObject::new_empty();
    object.put(text(tags::SOP_CLASS_UID, VR::UI, SECONDARY_CAPTURE_STORAGE));
    object.put(text(tags::SOP_INSTANCE_UID, VR::UI, &new_uid("secondary capture instance")));
    copy_patient_and_study(source, &mut object, false);
    object.put(text(tags::MODALITY, VR::CS, "OT"));
    object.put(text(tags::SERIES_INSTANCE_UID, VR::UI, &new_uid("secondary capture series")));
    object.put(text(tags::SERIES_NUMBER, VR::IS, &series_number.to_string()));
    object.put(text(tags::SERIES_DESCRIPTION, VR::LO, "volasso 3-D view"));
    // Type 2C: a rendering of both sides has no laterality to tell.
    object.put(DataElement::new(tags::LATERALITY, VR::CS, PrimitiveValue::Empty));
    object.put(text(tags::SERIES_DATE, VR::DA, &date));
    object.put(text(tags::SERIES_TIME, VR::TM, &time));
    put_equipment(&mut object);
    // SC Equipment: a workstation's rendering.
    object.put(text(tags::CONVERSION_TYPE, VR::CS, "WSD"));
    // General Image, SC Image.
    object.put(text(tags::INSTANCE_NUMBER, VR::IS, "1"));
    object.put(DataElement::new(tags::PATIENT_ORIENTATION, VR::CS, PrimitiveValue::Empty));
    object.put(texts(tags::IMAGE_TYPE, VR::CS, &["DERIVED".into(), "SECONDARY".into()]));
    object.put(text(tags::CONTENT_DATE, VR::DA, &date));
    object.put(text(tags::CONTENT_TIME, VR::TM, &time));
    object.put(text(tags::DATE_OF_SECONDARY_CAPTURE, VR::DA, &date));
    object.put(text(tags::TIME_OF_SECONDARY_CAPTURE, VR::TM, &time));
    object.put(text(tags::BURNED_IN_ANNOTATION, VR::CS, "NO"));
    object.put(text(tags::LOSSY_IMAGE_COMPRESSION, VR::CS, "00"));
    // Image Pixel.
    object.put(ushort(tags::SAMPLES_PER_PIXEL, 3));
    object.put(text(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, "RGB"));
    object.put(ushort(tags::PLANAR_CONFIGURATION, 0));
    object.put(ushort(tags::ROWS, rows));
    object.put(ushort(tags::COLUMNS, columns));
    object.put(ushort(tags::BITS_ALLOCATED, 8));
    object.put(ushort(tags::BITS_STORED, 8));
    object.put(ushort(tags::HIGH_BIT, 7));
    object.put(ushort(tags::PIXEL_REPRESENTATION, 0));
    object.put(DataElement::new(tags::PIXEL_DATA, VR::OB, PrimitiveValue::from(pixels)));
    with_meta(object, "Secondary Capture")
}
