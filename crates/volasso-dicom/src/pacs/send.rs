//! C-STORE SCU (PS3.4 Annex B): DICOM files stored to a PACS on one association. Each file's
//! SOP class is proposed in the file's own transfer syntax (and, for a native one, the other
//! native little-endian syntax), so compressed files go as they are and the PACS chooses among
//! equals; a file whose context the PACS refused is not sent.
//!
//! Never: reports a file as stored without the PACS's success or warning status for it, or
//! re-encodes compressed pixel data.

use super::{PacsError, Peer, chain, command, receive_command, receive_data, release, send_message};
use dicom_core::{DataElement, PrimitiveValue, VR, dicom_value};
use dicom_dictionary_std::tags;
use dicom_encoding::TransferSyntaxIndex;
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use serde::Serialize;
use std::path::{Path, PathBuf};

const EXPLICIT_LE: &str = "1.2.840.10008.1.2.1";
const IMPLICIT_LE: &str = "1.2.840.10008.1.2";

/// What became of one file: one JSON line.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SendReport {
    /// The file as given.
    pub file: PathBuf,
    /// SOPInstanceUID.
    pub sop_instance_uid: String,
    /// SOPClassUID.
    pub sop_class_uid: String,
    /// The transfer syntax it was sent in; `null` when it was not sent.
    pub transfer_syntax: Option<String>,
    /// The PACS's C-STORE status as 4 hex digits; `null` when it gave none.
    pub status: Option<String>,
    /// True only when the PACS answered success or a warning.
    pub stored: bool,
    /// The PACS's Error Comment, or why the file was not sent or not answered.
    pub problem: Option<String>,
}

/// One file read for sending.
struct Outgoing {
    path: PathBuf,
    object: dicom_object::DefaultDicomObject,
    sop_class: String,
    sop_instance: String,
    syntax: String,
}

/// Stores `files` to `peer`; one report per file, in order. Files that cannot be read are
/// refused before the association opens.
pub fn send(peer: &Peer, files: &[PathBuf]) -> Result<Vec<SendReport>, PacsError> {
    let mut outgoing = Vec::with_capacity(files.len());
    for path in files {
        outgoing.push(read(path)?);
    }
    let mut contexts: Vec<(String, Vec<String>)> = Vec::new();
    for file in &outgoing {
        let mut syntaxes = vec![file.syntax.clone()];
        match file.syntax.as_str() {
            EXPLICIT_LE => syntaxes.push(IMPLICIT_LE.into()),
            IMPLICIT_LE => syntaxes.push(EXPLICIT_LE.into()),
            _ => {}
        }
        if !contexts.iter().any(|(class, proposed)| *class == file.sop_class && proposed[0] == file.syntax) {
            contexts.push((file.sop_class.clone(), syntaxes));
        }
    }
    if contexts.len() > 128 {
        return Err(PacsError::File {
            problem: format!("{} SOP class and transfer syntax pairs; one association carries 128", contexts.len()),
            path: files[0].clone(),
        });
    }
    let mut association = peer.associate(&contexts, &[])?;
    let mut reports = Vec::with_capacity(outgoing.len());
    let mut broken: Option<String> = None;
    for (index, file) in outgoing.iter().enumerate() {
        let mut report = SendReport {
            file: file.path.clone(),
            sop_instance_uid: file.sop_instance.clone(),
            sop_class_uid: file.sop_class.clone(),
            transfer_syntax: None,
            status: None,
            stored: false,
            problem: None,
        };
        if let Some(problem) = &broken {
            report.problem = Some(format!("not sent: {problem}"));
            reports.push(report);
            continue;
        }
        // The file's own syntax first, else the other native one.
        let negotiated = association.presentation_contexts();
        let context = negotiated
            .iter()
            .find(|c| c.abstract_syntax == file.sop_class && c.transfer_syntax == file.syntax)
            .or_else(|| {
                negotiated.iter().find(|c| {
                    c.abstract_syntax == file.sop_class
                        && [EXPLICIT_LE, IMPLICIT_LE].contains(&file.syntax.as_str())
                        && [EXPLICIT_LE, IMPLICIT_LE].contains(&c.transfer_syntax.as_str())
                })
            })
            .map(|c| (c.id, c.transfer_syntax.clone()));
        let Some((context, syntax)) = context else {
            report.problem = Some("the PACS accepts neither this SOP class nor it in this transfer syntax".into());
            reports.push(report);
            continue;
        };
        let data = match TransferSyntaxRegistry.get(&syntax) {
            Some(ts) => {
                let mut bytes = Vec::new();
                file.object.write_dataset_with_ts(&mut bytes, ts).map(|_| bytes).map_err(|error| error.to_string())
            }
            None => Err(format!("unknown transfer syntax {syntax}")),
        };
        let data = match data {
            Ok(data) => data,
            Err(problem) => {
                report.problem = Some(format!("cannot encode the data set: {problem}"));
                reports.push(report);
                continue;
            }
        };
        report.transfer_syntax = Some(syntax);
        let message_id = u16::try_from(index + 1).unwrap_or(u16::MAX);
        let extra = vec![
            DataElement::new(tags::AFFECTED_SOP_INSTANCE_UID, VR::UI, PrimitiveValue::from(file.sop_instance.as_str())),
            DataElement::new(tags::PRIORITY, VR::US, dicom_value!(U16, [0])),
        ];
        let answer = send_message(
            &mut association,
            context,
            command(0x0001, message_id, &file.sop_class, extra, true),
            Some(&data),
        )
        .and_then(|()| receive_command(&mut association));
        match answer {
            Ok(response) if response.field == 0x8001 => {
                if response.has_data {
                    let _ = receive_data(&mut association, 1 << 20, |_| Ok(()));
                }
                report.status = Some(format!("{:04X}", response.status));
                report.stored = response.status == 0x0000 || super::is_warning(response.status);
                report.problem = response.comment;
            }
            Ok(response) => {
                let problem = format!("a command {:#06x} where a C-STORE response was expected", response.field);
                report.problem = Some(problem.clone());
                broken = Some(problem);
            }
            Err(problem) => {
                report.problem = Some(format!("no answer: {problem}"));
                broken = Some(problem);
            }
        }
        reports.push(report);
    }
    if broken.is_some() {
        let _ = association.abort();
    } else {
        release(association, peer);
    }
    Ok(reports)
}

/// A DICOM file with its SOP class, instance and transfer syntax.
fn read(path: &Path) -> Result<Outgoing, PacsError> {
    let refuse = |problem: String| PacsError::File { problem, path: path.to_path_buf() };
    let metadata = std::fs::metadata(path).map_err(|error| refuse(error.to_string()))?;
    if !metadata.is_file() {
        return Err(refuse("not a regular file".into()));
    }
    let object =
        dicom_object::open_file(path).map_err(|error| refuse(format!("not a DICOM file ({})", chain(&error))))?;
    let meta = object.meta();
    let clean = |text: &str| text.trim_end_matches(['\0', ' ']).to_string();
    let (sop_class, sop_instance, syntax) = (
        clean(meta.media_storage_sop_class_uid()),
        clean(meta.media_storage_sop_instance_uid()),
        clean(meta.transfer_syntax()),
    );
    if sop_class.is_empty() || sop_instance.is_empty() {
        return Err(refuse("its file meta names no SOP class or instance".into()));
    }
    if TransferSyntaxRegistry.get(&syntax).is_none() {
        return Err(refuse(format!("its transfer syntax {syntax} is unknown")));
    }
    Ok(Outgoing { path: path.to_path_buf(), object, sop_class, sop_instance, syntax })
}
