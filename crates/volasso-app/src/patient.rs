//! Whose scan it is, as a bedside kiosk shows it (clinical mode): the patient's name, ID, birth
//! date and sex, the study's date, the modality and the series' description, read from the
//! DICOM header when the scan opens or its card is made, on the work screen's top bar and on
//! the chooser's card. Every clinical viewer shows them so that nobody treats the wrong
//! patient. A scan from another format says it carries no patient data. In demo mode nothing is
//! read and nothing is shown.
//!
//! Never: logs a patient's data, or reads it in demo mode.

use crate::words::tr;
use volasso_core::phantom::source::VolumeSource;
use volasso_core::volume::dicom::{PatientIdentity, PatientShown, SeriesSummary, list_series};
use volasso_core::volume::limits::ReadLimits;

/// What the kiosk knows of a scan's patient.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Patient {
    /// Demo mode: not read, not shown.
    #[default]
    NotShown,
    /// The scan is not DICOM (a volume file, the demo): it carries no patient data.
    NoPatientData,
    /// From the series' DICOM header.
    Dicom { identity: PatientIdentity, modality: String, description: String },
}

/// The DICOM series `source` is (its header, no pixels), with its patient when `shown`;
/// `None` for a scan that is not DICOM.
pub fn series_summary(source: &VolumeSource, shown: PatientShown, limits: &ReadLimits) -> Option<SeriesSummary> {
    let path = source.path()?;
    let series_uid = match source {
        VolumeSource::Series { series_uid, .. } => Some(series_uid.as_str()),
        _ => None,
    };
    let listed = list_series(path, shown, limits).ok()?;
    listed
        .into_iter()
        .filter(|summary| summary.unreadable.is_none())
        .find(|summary| series_uid.is_none_or(|uid| summary.series_uid == uid))
}

impl Patient {
    /// The patient of the series `summary` describes (`None`: not DICOM) when `shown`.
    pub fn of(summary: Option<&SeriesSummary>, shown: PatientShown) -> Patient {
        if shown == PatientShown::Hidden {
            return Patient::NotShown;
        }
        match summary {
            Some(SeriesSummary { patient: Some(identity), modality, description, .. }) => Patient::Dicom {
                identity: identity.clone(),
                modality: modality.clone(),
                description: description.clone(),
            },
            _ => Patient::NoPatientData,
        }
    }

    /// The line the screens show, in the screens' language (its words; names and IDs as the
    /// header has them); empty when not shown.
    pub fn line(&self) -> String {
        let Patient::Dicom { identity, modality, description } = self else {
            return match self {
                Patient::NoPatientData => tr("No patient data (not a DICOM scan)"),
                _ => String::new(),
            };
        };
        let name = person_name(&identity.name);
        let mut parts = vec![if name.is_empty() { tr("Name not given") } else { name }];
        parts.push(if identity.id.trim().is_empty() {
            tr("ID not given")
        } else {
            format!("ID {}", identity.id.trim())
        });
        if let Some(born) = date(&identity.birth_date) {
            parts.push(tr(&format!("born {born}")));
        }
        if !identity.sex.trim().is_empty() {
            parts.push(identity.sex.trim().to_string());
        }
        if let Some(study) = date(&identity.study_date) {
            parts.push(tr(&format!("study {study}")));
        }
        let series =
            [modality.trim(), description.trim()].into_iter().filter(|part| !part.is_empty()).collect::<Vec<_>>();
        if !series.is_empty() {
            parts.push(series.join(" "));
        }
        parts.join(" · ")
    }
}

/// A DICOM person name (`FAMILY^GIVEN^MIDDLE^PREFIX^SUFFIX`, an ideographic part after `=`
/// dropped) as `FAMILY, GIVEN MIDDLE`.
fn person_name(name: &str) -> String {
    let alphabetic = name.split('=').next().unwrap_or_default();
    let mut parts = alphabetic.split('^').map(str::trim);
    let family = parts.next().unwrap_or_default();
    let given: Vec<&str> = parts.take(2).filter(|part| !part.is_empty()).collect();
    match (family.is_empty(), given.is_empty()) {
        (_, true) => family.to_string(),
        (true, false) => given.join(" "),
        (false, false) => format!("{family}, {}", given.join(" ")),
    }
}

/// A DICOM date (`YYYYMMDD`) as `YYYY-MM-DD`; `None` when it is not one.
fn date(text: &str) -> Option<String> {
    let text = text.trim();
    let valid = text.len() == 8 && text.bytes().all(|byte| byte.is_ascii_digit());
    valid.then(|| format!("{}-{}-{}", &text[..4], &text[4..6], &text[6..]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn identity(name: &str, id: &str, birth: &str, sex: &str, study: &str) -> PatientIdentity {
        PatientIdentity {
            name: name.into(),
            id: id.into(),
            birth_date: birth.into(),
            sex: sex.into(),
            study_date: study.into(),
        }
    }

    #[test]
    fn the_line_names_the_patient_the_study_and_the_series() {
        let patient = Patient::Dicom {
            identity: identity("DOE^JOHN^Q", "12345", "19700131", "M", "20261201"),
            modality: "CT".into(),
            description: "Chest 5mm".into(),
        };
        assert_eq!(patient.line(), "DOE, JOHN Q · ID 12345 · born 1970-01-31 · M · study 2026-12-01 · CT Chest 5mm");
        let sparse = Patient::Dicom {
            identity: identity("", " ", "1970", "", ""),
            modality: "MR".into(),
            description: "".into(),
        };
        assert_eq!(sparse.line(), "Name not given · ID not given · MR");
        assert_eq!(Patient::NotShown.line(), "");
        assert_eq!(Patient::NoPatientData.line(), "No patient data (not a DICOM scan)");
    }

    #[test]
    fn person_names_read_family_given_and_middle() {
        assert_eq!(person_name("PLASTIC"), "PLASTIC");
        assert_eq!(person_name("Doe^Jane"), "Doe, Jane");
        assert_eq!(person_name("^Jane"), "Jane");
        assert_eq!(person_name("Yamada^Tarou=山田^太郎"), "Yamada, Tarou");
        assert_eq!(person_name(""), "");
    }

    #[test]
    fn the_philips_series_shows_its_patient_in_clinical_mode_only() {
        let folder =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/dicom/philips_phantom_5mm");
        let source = VolumeSource::Path(folder);
        let limits = ReadLimits::default();
        let hidden = series_summary(&source, PatientShown::Hidden, &limits);
        assert!(hidden.as_ref().is_some_and(|summary| summary.patient.is_none()), "nothing read in demo mode");
        assert_eq!(Patient::of(hidden.as_ref(), PatientShown::Hidden), Patient::NotShown);
        let shown = series_summary(&source, PatientShown::Shown, &limits);
        let Patient::Dicom { identity, modality, .. } = Patient::of(shown.as_ref(), PatientShown::Shown) else {
            panic!("the Philips series is DICOM");
        };
        assert_eq!((identity.id.as_str(), modality.as_str()), ("PLASTIC", "CT"));
        assert_eq!(series_summary(&VolumeSource::Demo, PatientShown::Shown, &limits), None);
        assert_eq!(Patient::of(None, PatientShown::Shown), Patient::NoPatientData);
    }
}
