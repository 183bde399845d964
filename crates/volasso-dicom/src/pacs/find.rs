//! C-FIND SCU (PS3.4 Annex C, Study Root Query/Retrieve Information Model - FIND): the studies
//! that match a query, then, on the same association, each study's series.
//!
//! Never: asks for or returns a patient's name, ID or birth date (a patient ID may be matched
//! on, not shown).

use super::{
    MOST_IDENTIFIER_BYTES, PacsError, Peer, command, decode, encode, is_pending, native_syntaxes, priority,
    receive_command, receive_data, release, send_message,
};
use dicom_core::{DataElement, PrimitiveValue, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::InMemDicomObject;
use serde::Serialize;

/// What to match (empty: any).
#[derive(Clone, Debug, Default)]
pub struct FindQuery {
    /// PatientID, exactly.
    pub patient_id: Option<String>,
    /// AccessionNumber, exactly.
    pub accession_number: Option<String>,
    /// A modality among the study's (ModalitiesInStudy), e.g. `CT`.
    pub modality: Option<String>,
    /// Studies on or after this date, `YYYYMMDD`.
    pub since: Option<String>,
}

/// One study that matched: one JSON line.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct StudyFound {
    /// StudyInstanceUID.
    pub study_uid: String,
    /// StudyDate (`YYYYMMDD`), empty when the PACS sent none.
    pub study_date: String,
    /// AccessionNumber.
    pub accession_number: String,
    /// StudyDescription.
    pub description: String,
    /// ModalitiesInStudy.
    pub modalities: Vec<String>,
    /// The study's series.
    pub series: Vec<SeriesFound>,
    /// PatientName, for the kiosk's list only: never printed or logged.
    #[serde(skip)]
    pub patient_name: String,
    /// PatientID, for the kiosk's list only: never printed or logged.
    #[serde(skip)]
    pub patient_id: String,
}

/// One series of a study.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SeriesFound {
    /// SeriesInstanceUID.
    pub series_uid: String,
    /// Modality.
    pub modality: String,
    /// SeriesDescription.
    pub description: String,
    /// SeriesNumber, `null` when absent.
    pub number: Option<i64>,
    /// NumberOfSeriesRelatedInstances, `null` when the PACS did not say.
    pub images: Option<u64>,
}

pub(super) const FIND: &str = uids::STUDY_ROOT_QUERY_RETRIEVE_INFORMATION_MODEL_FIND;

/// The studies matching `query` on `peer`, each with its series.
pub fn find(peer: &Peer, query: &FindQuery) -> Result<Vec<StudyFound>, PacsError> {
    let mut association = peer.associate(&[(FIND.to_string(), native_syntaxes())], &[])?;
    let result = find_on(&mut association, peer, query);
    match result {
        Ok(studies) => {
            release(association, peer);
            Ok(studies)
        }
        Err(error) => {
            let _ = association.abort();
            Err(error)
        }
    }
}

fn find_on(association: &mut super::Association, peer: &Peer, query: &FindQuery) -> Result<Vec<StudyFound>, PacsError> {
    let empty = |tag, vr| DataElement::new(tag, vr, PrimitiveValue::Empty);
    let given = |tag, vr, value: &Option<String>| match value {
        Some(value) => DataElement::new(tag, vr, PrimitiveValue::from(value.as_str())),
        None => DataElement::new(tag, vr, PrimitiveValue::Empty),
    };
    let studies = InMemDicomObject::from_element_iter([
        DataElement::new(tags::QUERY_RETRIEVE_LEVEL, VR::CS, PrimitiveValue::from("STUDY")),
        empty(tags::STUDY_INSTANCE_UID, VR::UI),
        DataElement::new(
            tags::STUDY_DATE,
            VR::DA,
            query.since.as_ref().map_or(PrimitiveValue::Empty, |since| PrimitiveValue::from(format!("{since}-"))),
        ),
        given(tags::ACCESSION_NUMBER, VR::SH, &query.accession_number),
        given(tags::PATIENT_ID, VR::LO, &query.patient_id),
        empty(tags::PATIENT_NAME, VR::PN),
        empty(tags::STUDY_DESCRIPTION, VR::LO),
        given(tags::MODALITIES_IN_STUDY, VR::CS, &query.modality),
    ]);
    let mut found = Vec::new();
    for answer in query_all(association, peer, &studies, 1)? {
        let text = |tag| answer_text(&answer, tag);
        let study_uid = text(tags::STUDY_INSTANCE_UID);
        if study_uid.is_empty() {
            continue;
        }
        found.push(StudyFound {
            study_date: text(tags::STUDY_DATE),
            accession_number: text(tags::ACCESSION_NUMBER),
            description: text(tags::STUDY_DESCRIPTION),
            modalities: text(tags::MODALITIES_IN_STUDY)
                .split('\\')
                .map(str::trim)
                .filter(|m| !m.is_empty())
                .map(str::to_string)
                .collect(),
            series: Vec::new(),
            patient_name: text(tags::PATIENT_NAME).replace('^', " ").trim().to_string(),
            patient_id: text(tags::PATIENT_ID),
            study_uid,
        });
    }
    for (index, study) in found.iter_mut().enumerate() {
        let message_id = u16::try_from(index + 2).unwrap_or(u16::MAX);
        study.series = series_of(association, peer, &study.study_uid, None, message_id)?;
    }
    Ok(found)
}

/// The series of `study_uid` (only `series_uid`, when given), by SeriesNumber: one C-FIND at
/// series level on an association with a C-FIND context.
pub(super) fn series_of(
    association: &mut super::Association,
    peer: &Peer,
    study_uid: &str,
    series_uid: Option<&str>,
    message_id: u16,
) -> Result<Vec<SeriesFound>, PacsError> {
    let empty = |tag, vr| DataElement::new(tag, vr, PrimitiveValue::Empty);
    let identifier = InMemDicomObject::from_element_iter([
        DataElement::new(tags::QUERY_RETRIEVE_LEVEL, VR::CS, PrimitiveValue::from("SERIES")),
        DataElement::new(tags::STUDY_INSTANCE_UID, VR::UI, PrimitiveValue::from(study_uid)),
        match series_uid {
            Some(uid) => DataElement::new(tags::SERIES_INSTANCE_UID, VR::UI, PrimitiveValue::from(uid)),
            None => empty(tags::SERIES_INSTANCE_UID, VR::UI),
        },
        empty(tags::MODALITY, VR::CS),
        empty(tags::SERIES_DESCRIPTION, VR::LO),
        empty(tags::SERIES_NUMBER, VR::IS),
        empty(tags::NUMBER_OF_SERIES_RELATED_INSTANCES, VR::IS),
    ]);
    let mut series = Vec::new();
    for answer in query_all(association, peer, &identifier, message_id)? {
        let text = |tag| answer_text(&answer, tag);
        let series_uid = text(tags::SERIES_INSTANCE_UID);
        if series_uid.is_empty() {
            continue;
        }
        series.push(SeriesFound {
            series_uid,
            modality: text(tags::MODALITY),
            description: text(tags::SERIES_DESCRIPTION),
            number: text(tags::SERIES_NUMBER).trim().parse().ok(),
            images: text(tags::NUMBER_OF_SERIES_RELATED_INSTANCES).trim().parse().ok(),
        });
    }
    series.sort_by(|a, b| (a.number, &a.series_uid).cmp(&(b.number, &b.series_uid)));
    Ok(series)
}

fn answer_text(answer: &InMemDicomObject, tag: dicom_core::Tag) -> String {
    answer
        .get(tag)
        .and_then(|element| element.to_str().ok())
        .map(|text| text.trim_end_matches(['\0', ' ']).trim().to_string())
        .unwrap_or_default()
}

/// Sends one C-FIND request and collects its pending answers' identifiers.
fn query_all(
    association: &mut super::Association,
    peer: &Peer,
    identifier: &InMemDicomObject,
    message_id: u16,
) -> Result<Vec<InMemDicomObject>, PacsError> {
    let protocol = |problem: String| PacsError::Protocol { peer: peer.describe(), problem };
    let context =
        association.context_for(FIND).ok_or_else(|| protocol("the PACS accepted no C-FIND context".into()))?;
    let data = encode(identifier, &context.1).map_err(protocol)?;
    let request = command(0x0020, message_id, FIND, vec![priority()], true);
    send_message(association, context.0, request, Some(&data)).map_err(protocol)?;
    let mut answers = Vec::new();
    loop {
        let response = receive_command(association).map_err(protocol)?;
        if response.field != 0x8020 {
            return Err(protocol(format!("a command {:#06x} where a C-FIND response was expected", response.field)));
        }
        let mut bytes = Vec::new();
        if response.has_data {
            receive_data(association, MOST_IDENTIFIER_BYTES as u64, |chunk| {
                bytes.extend_from_slice(chunk);
                Ok(())
            })
            .map_err(protocol)?;
        }
        if is_pending(response.status) {
            answers.push(decode(&bytes, &context.1).map_err(protocol)?);
            continue;
        }
        if response.status == 0x0000 {
            return Ok(answers);
        }
        return Err(PacsError::Status {
            peer: peer.describe(),
            operation: "C-FIND",
            status: response.status,
            comment: response.comment,
        });
    }
}
