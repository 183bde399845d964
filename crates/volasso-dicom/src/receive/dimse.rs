//! The DIMSE messages the storage SCP exchanges (PS3.7 §9.1.1 C-STORE, §9.1.5 C-ECHO): command
//! sets read from and written to Implicit VR Little Endian bytes, the statuses it answers
//! with, and the SOP classes it accepts.
//!
//! Never: touches a socket or a file.

use dicom_core::value::PrimitiveValue;
use dicom_core::{DataElement, VR, dicom_value};
use dicom_dictionary_std::{tags, uids};
use dicom_object::InMemDicomObject;
use dicom_transfer_syntax_registry::entries::IMPLICIT_VR_LITTLE_ENDIAN;

/// The storage SOP classes accepted: CT and MR images, enhanced and legacy-converted
/// enhanced ones included (the images this reader turns into volumes).
pub const STORAGE_SOP_CLASSES: [&str; 8] = [
    uids::CT_IMAGE_STORAGE,
    uids::ENHANCED_CT_IMAGE_STORAGE,
    uids::LEGACY_CONVERTED_ENHANCED_CT_IMAGE_STORAGE,
    uids::CT_IMAGE_STORAGE_FOR_PROCESSING,
    uids::ENHANCED_CT_IMAGE_STORAGE_FOR_PROCESSING,
    uids::MR_IMAGE_STORAGE,
    uids::ENHANCED_MR_IMAGE_STORAGE,
    uids::LEGACY_CONVERTED_ENHANCED_MR_IMAGE_STORAGE,
];

/// C-ECHO's SOP class.
pub const VERIFICATION: &str = uids::VERIFICATION;

/// DIMSE statuses (PS3.4 Annex B.2.3, PS3.7 Annex C).
pub mod status {
    pub const SUCCESS: u16 = 0x0000;
    /// Refused: SOP class not supported.
    pub const SOP_CLASS_NOT_SUPPORTED: u16 = 0x0122;
    /// Refused: out of resources (the data partition is too full).
    pub const OUT_OF_RESOURCES: u16 = 0xA700;
    /// Error: data set does not match SOP class.
    pub const DATA_SET_DOES_NOT_MATCH: u16 = 0xA900;
    /// Error: cannot understand.
    pub const CANNOT_UNDERSTAND: u16 = 0xC000;
    /// Failure: processing failure (the file could not be written).
    pub const PROCESSING_FAILURE: u16 = 0x0110;
}

/// CommandField values.
pub const C_STORE_RQ: u16 = 0x0001;
pub const C_ECHO_RQ: u16 = 0x0030;

/// The fields of a request command set that the SCP uses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Command {
    pub field: u16,
    pub message_id: u16,
    pub affected_sop_class: String,
    pub affected_sop_instance: String,
    /// CommandDataSetType: anything but 0x0101 means a data set follows.
    pub has_data_set: bool,
}

/// Parses a command set (always Implicit VR Little Endian); `None` when it is not one.
pub fn parse_command(bytes: &[u8]) -> Option<Command> {
    let object = InMemDicomObject::read_dataset_with_ts(bytes, &IMPLICIT_VR_LITTLE_ENDIAN.erased()).ok()?;
    let number = |tag| object.get(tag).and_then(|element| element.to_int::<u16>().ok());
    let uid = |tag| {
        object
            .get(tag)
            .and_then(|element| element.to_str().ok())
            .map(|text| text.trim_end_matches(['\0', ' ']).to_string())
            .unwrap_or_default()
    };
    Some(Command {
        field: number(tags::COMMAND_FIELD)?,
        message_id: number(tags::MESSAGE_ID).unwrap_or(0),
        affected_sop_class: uid(tags::AFFECTED_SOP_CLASS_UID),
        affected_sop_instance: uid(tags::AFFECTED_SOP_INSTANCE_UID),
        has_data_set: number(tags::COMMAND_DATA_SET_TYPE).is_some_and(|kind| kind != 0x0101),
    })
}

/// The longest Error Comment (0000,0902): one LO value.
pub const MOST_COMMENT_CHARS: usize = 64;

/// The response to `request` (C-STORE-RSP or C-ECHO-RSP) with `status` and, for a failure, an
/// Error Comment (cut to [`MOST_COMMENT_CHARS`] printable ASCII characters), as command bytes.
pub fn response(request: &Command, status: u16, comment: Option<&str>) -> Vec<u8> {
    let mut elements = vec![
        DataElement::new(tags::COMMAND_FIELD, VR::US, dicom_value!(U16, [request.field | 0x8000])),
        DataElement::new(tags::MESSAGE_ID_BEING_RESPONDED_TO, VR::US, dicom_value!(U16, [request.message_id])),
        DataElement::new(tags::COMMAND_DATA_SET_TYPE, VR::US, dicom_value!(U16, [0x0101])),
        DataElement::new(tags::STATUS, VR::US, dicom_value!(U16, [status])),
    ];
    if !request.affected_sop_class.is_empty() {
        elements.push(DataElement::new(
            tags::AFFECTED_SOP_CLASS_UID,
            VR::UI,
            PrimitiveValue::from(request.affected_sop_class.as_str()),
        ));
    }
    if !request.affected_sop_instance.is_empty() {
        elements.push(DataElement::new(
            tags::AFFECTED_SOP_INSTANCE_UID,
            VR::UI,
            PrimitiveValue::from(request.affected_sop_instance.as_str()),
        ));
    }
    if let Some(comment) = comment.map(error_comment).filter(|comment| !comment.is_empty()) {
        elements.push(DataElement::new(tags::ERROR_COMMENT, VR::LO, PrimitiveValue::from(comment)));
    }
    let mut bytes = Vec::new();
    // Writing a command set of six short elements into memory cannot fail.
    let _ = InMemDicomObject::command_from_element_iter(elements)
        .write_dataset_with_ts(&mut bytes, &IMPLICIT_VR_LITTLE_ENDIAN.erased());
    bytes
}

/// `text` as an Error Comment: printable ASCII without backslashes (LO's repertoire without
/// a character set), runs of anything else as one space, at most [`MOST_COMMENT_CHARS`].
pub fn error_comment(text: &str) -> String {
    let mut comment = String::new();
    for character in text.chars() {
        let keep = character.is_ascii_graphic() && character != '\\';
        if keep {
            comment.push(character);
        } else if !comment.ends_with(' ') && !comment.is_empty() {
            comment.push(' ');
        }
        if comment.len() >= MOST_COMMENT_CHARS {
            break;
        }
    }
    comment.truncate(MOST_COMMENT_CHARS);
    comment.trim_end().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_response_answers_its_request_and_parses_back() {
        let request = Command {
            field: C_STORE_RQ,
            message_id: 7,
            affected_sop_class: uids::CT_IMAGE_STORAGE.into(),
            affected_sop_instance: "1.2.3.4".into(),
            has_data_set: true,
        };
        let parsed = parse_command(&response(&request, status::OUT_OF_RESOURCES, None)).unwrap();
        assert_eq!(parsed.field, 0x8001);
        assert_eq!(parsed.affected_sop_instance, "1.2.3.4");
        assert!(!parsed.has_data_set);
        let object = InMemDicomObject::read_dataset_with_ts(
            response(&request, status::OUT_OF_RESOURCES, None).as_slice(),
            &IMPLICIT_VR_LITTLE_ENDIAN.erased(),
        )
        .unwrap();
        assert_eq!(object.get(tags::STATUS).unwrap().to_int::<u16>().unwrap(), 0xA700);
        assert_eq!(object.get(tags::MESSAGE_ID_BEING_RESPONDED_TO).unwrap().to_int::<u16>().unwrap(), 7);
        assert!(object.get(tags::ERROR_COMMENT).is_none());
        assert!(parse_command(b"not a command").is_none());
    }

    #[test]
    fn a_failure_carries_a_short_printable_error_comment() {
        let request = Command {
            field: C_STORE_RQ,
            message_id: 1,
            affected_sop_class: uids::CT_IMAGE_STORAGE.into(),
            affected_sop_instance: "1.2.3".into(),
            has_data_set: true,
        };
        let long = "PixelData holds 1000 bytes\nbut Rows x Columns \\ needs 524288, which is far more than it has";
        let bytes = response(&request, status::CANNOT_UNDERSTAND, Some(long));
        let object =
            InMemDicomObject::read_dataset_with_ts(bytes.as_slice(), &IMPLICIT_VR_LITTLE_ENDIAN.erased()).unwrap();
        let comment = object.get(tags::ERROR_COMMENT).unwrap().to_str().unwrap().trim_end().to_string();
        assert!(comment.starts_with("PixelData holds 1000 bytes but Rows x Columns needs"), "{comment}");
        assert!(comment.len() <= MOST_COMMENT_CHARS && comment.bytes().all(|b| b.is_ascii_graphic() || b == b' '));
        assert_eq!(object.get(tags::STATUS).unwrap().to_int::<u16>().unwrap(), 0xC000);
    }
}
