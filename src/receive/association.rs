//! One association, from negotiation to release or abort (PS3.8 upper layer through dicom-ul,
//! PS3.7 DIMSE on top).
//!
//! Each C-STORE's data set is streamed to its own file in the association's staging folder as
//! its P-DATA fragments arrive (preamble, a file meta group built from the command and the
//! presentation context, then the data set bytes exactly as sent), so memory stays at one PDU
//! whatever the series' length. When the last fragment is written the file is flushed to disk
//! and its identity read back ([`crate::volume::dicom::read_identity`]); only then does the
//! SCU get a success status. The file is renamed to the hash of its SOPInstanceUID inside a
//! folder per series.
//!
//! A normal release publishes what arrived ([`Store::publish`]); an abort, a broken connection
//! or an idle peer (no PDU for [`IDLE_TIMEOUT`]) removes the staging folder, so a half-sent
//! series leaves nothing.
//!
//! Never: logs or prints patient data, or names a file after DICOM text.

use super::ReceiveOptions;
use super::dimse::{self, Command, status};
use super::store::{ReceivedImage, SeriesReport, Store, remove_path, series_name, short_hash, used_fraction};
use crate::volume::limits::ReadLimits;
use dicom_object::FileMetaTableBuilder;
use dicom_ul::Pdu;
use dicom_ul::association::ServerAssociationOptions;
use dicom_ul::pdu::{AssociationRJServiceUserReason, PDataValue, PDataValueType, UserIdentity};
use std::collections::BTreeMap;
use std::io::Write;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A peer that sends nothing for this long loses its association (and what it sent).
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(60);
/// The largest PDU this SCP accepts; the sender splits data sets into PDUs of this size.
const MAX_PDU_BYTES: u32 = 64 * 1024;
/// A command set is a few hundred bytes; more is not a command.
const MOST_COMMAND_BYTES: usize = 64 * 1024;

/// Who may store: the called AE title must be ours, the calling one in the list (any when the
/// list is empty).
struct AllowedTitles {
    calling: Vec<String>,
}

impl dicom_ul::association::server::AccessControl for AllowedTitles {
    fn check_access(
        &self,
        this_ae_title: &str,
        calling_ae_title: &str,
        called_ae_title: &str,
        _user_identity: Option<&UserIdentity>,
    ) -> Result<(), AssociationRJServiceUserReason> {
        if called_ae_title.trim() != this_ae_title.trim() {
            return Err(AssociationRJServiceUserReason::CalledAETitleNotRecognized);
        }
        if !self.calling.is_empty() && !self.calling.iter().any(|title| title == calling_ae_title.trim()) {
            return Err(AssociationRJServiceUserReason::CallingAETitleNotRecognized);
        }
        Ok(())
    }
}

/// How an association ended.
#[derive(Debug)]
pub enum Outcome {
    /// Released normally: one report per series received.
    Released(Vec<SeriesReport>),
    /// Refused at negotiation (wrong AE title, nothing acceptable).
    Refused(String),
    /// Aborted, broken or timed out: everything it sent was removed.
    Dropped(String),
}

/// Negotiates and serves one association on `stream`.
pub fn serve(stream: TcpStream, options: &ReceiveOptions, store: &Store) -> Outcome {
    let mut negotiation = ServerAssociationOptions::new()
        .ae_access_control(AllowedTitles { calling: options.allowed_calling_ae.clone() })
        .ae_title(options.ae_title.as_str())
        .max_pdu_length(MAX_PDU_BYTES)
        .read_timeout(IDLE_TIMEOUT)
        .write_timeout(IDLE_TIMEOUT)
        .with_abstract_syntax(dimse::VERIFICATION);
    for sop_class in dimse::STORAGE_SOP_CLASSES {
        negotiation = negotiation.with_abstract_syntax(sop_class);
    }
    for syntax in super::accepted_transfer_syntaxes() {
        negotiation = negotiation.with_transfer_syntax(syntax);
    }
    let mut association = match negotiation.establish(stream) {
        Ok(association) => association,
        Err(error) => return Outcome::Refused(error.to_string()),
    };
    let calling_ae = dicom_ul::association::Association::peer_ae_title(&association).trim().to_string();
    let folder = match store.association_folder() {
        Ok(folder) => folder,
        Err(error) => {
            let _ = association.abort();
            return Outcome::Dropped(format!("cannot create a staging folder ({error})"));
        }
    };
    let contexts: Vec<(u8, String, String)> = association
        .presentation_contexts()
        .iter()
        .map(|context| (context.id, context.abstract_syntax.clone(), context.transfer_syntax.clone()))
        .collect();
    let mut session = Session::new(folder.clone(), options.max_disk_use_fraction, contexts, store.data_dir());
    let ended = loop {
        let pdu = match association.receive() {
            Ok(pdu) => pdu,
            Err(error) => break Err(format!("the connection ended without a release ({error})")),
        };
        match pdu {
            Pdu::PData { data } => {
                let mut failed = None;
                for value in data {
                    match session.take(value) {
                        Ok(Some(response)) => {
                            if let Err(error) = association.send(&response) {
                                failed = Some(format!("cannot answer the sender ({error})"));
                                break;
                            }
                        }
                        Ok(None) => {}
                        Err(problem) => {
                            failed = Some(problem);
                            break;
                        }
                    }
                }
                if let Some(problem) = failed {
                    let _ = association.abort();
                    break Err(problem);
                }
            }
            Pdu::ReleaseRQ => {
                let _ = association.send(&Pdu::ReleaseRP);
                break Ok(());
            }
            Pdu::AbortRQ { .. } => break Err("the sender aborted the association".to_string()),
            other => {
                let _ = association.abort();
                break Err(format!("unexpected {}", other.short_description()));
            }
        }
    };
    match ended {
        Ok(()) if session.current.is_none() => {
            let received: Vec<ReceivedImage> = session.received.into_values().collect();
            Outcome::Released(store.publish(&folder, &received, &calling_ae))
        }
        Ok(()) => {
            remove_path(&folder);
            Outcome::Dropped("released in the middle of a data set".into())
        }
        Err(problem) => {
            remove_path(&folder);
            Outcome::Dropped(problem)
        }
    }
}

/// The image being received: its command and its file (none when it is being refused).
struct Incoming {
    command: Command,
    context_id: u8,
    file: Option<(std::io::BufWriter<std::fs::File>, PathBuf)>,
    /// The status to answer with when the data set ends; success unless refused up front.
    status: u16,
}

/// The state of one association between PDUs.
struct Session {
    folder: PathBuf,
    data_dir: PathBuf,
    max_disk_use_fraction: f64,
    /// (presentation context id, abstract syntax, transfer syntax) of accepted contexts.
    contexts: Vec<(u8, String, String)>,
    command_bytes: Vec<u8>,
    current: Option<Incoming>,
    /// By file: the same image sent twice in one association is one file.
    received: BTreeMap<PathBuf, ReceivedImage>,
    next_file: u64,
    limits: ReadLimits,
}

impl Session {
    fn new(
        folder: PathBuf,
        max_disk_use_fraction: f64,
        contexts: Vec<(u8, String, String)>,
        data_dir: &Path,
    ) -> Session {
        Session {
            folder,
            data_dir: data_dir.to_path_buf(),
            max_disk_use_fraction,
            contexts,
            command_bytes: Vec::new(),
            current: None,
            received: BTreeMap::new(),
            next_file: 0,
            limits: ReadLimits::default(),
        }
    }

    /// Takes one P-DATA value; returns the PDU to answer with, if any, or why the association
    /// must end.
    fn take(&mut self, value: PDataValue) -> Result<Option<Pdu>, String> {
        match value.value_type {
            PDataValueType::Command => {
                if self.current.is_some() {
                    return Err("a command arrived inside a data set".into());
                }
                if self.command_bytes.len() + value.data.len() > MOST_COMMAND_BYTES {
                    return Err(format!("a command set longer than {MOST_COMMAND_BYTES} bytes"));
                }
                self.command_bytes.extend(&value.data);
                if !value.is_last {
                    return Ok(None);
                }
                let bytes = std::mem::take(&mut self.command_bytes);
                let command = dimse::parse_command(&bytes).ok_or("a command set that cannot be read")?;
                self.command(command, value.presentation_context_id)
            }
            PDataValueType::Data => {
                let Some(incoming) = self.current.as_mut() else {
                    return Err("a data set arrived without a command".into());
                };
                if let Some((writer, _)) = incoming.file.as_mut()
                    && let Err(error) = writer.write_all(&value.data)
                {
                    log::error!("cannot write a received image: {error}");
                    incoming.status = status::PROCESSING_FAILURE;
                    incoming.file = None;
                }
                if !value.is_last {
                    return Ok(None);
                }
                let incoming = self.current.take().ok_or("no data set in progress")?;
                let status = self.finish(incoming.file, incoming.status, &incoming.command);
                Ok(Some(respond(incoming.context_id, &incoming.command, status)))
            }
        }
    }

    fn command(&mut self, command: Command, context_id: u8) -> Result<Option<Pdu>, String> {
        match command.field {
            dimse::C_ECHO_RQ => Ok(Some(respond(context_id, &command, status::SUCCESS))),
            dimse::C_STORE_RQ if command.has_data_set => {
                let mut status = self.refusal(&command, context_id).unwrap_or(status::SUCCESS);
                let mut file = None;
                if status == status::SUCCESS {
                    match self.open_file(&command, context_id) {
                        Ok(opened) => file = Some(opened),
                        Err(error) => {
                            log::error!("cannot create a file for a received image: {error}");
                            status = status::PROCESSING_FAILURE;
                        }
                    }
                }
                self.current = Some(Incoming { command, context_id, file, status });
                Ok(None)
            }
            dimse::C_STORE_RQ => Ok(Some(respond(context_id, &command, status::CANNOT_UNDERSTAND))),
            other => Err(format!("a DIMSE command this SCP does not serve (CommandField {other:#06x})")),
        }
    }

    /// Why a C-STORE is refused before its data arrives: a SOP class other than the context's
    /// or not a CT/MR image, or a data partition fuller than allowed.
    fn refusal(&self, command: &Command, context_id: u8) -> Option<u16> {
        let context = self.contexts.iter().find(|(id, _, _)| *id == context_id);
        let sop_class_fits = context.is_some_and(|(_, abstract_syntax, _)| {
            abstract_syntax == &command.affected_sop_class
                && dimse::STORAGE_SOP_CLASSES.contains(&command.affected_sop_class.as_str())
        });
        if !sop_class_fits {
            return Some(status::SOP_CLASS_NOT_SUPPORTED);
        }
        match used_fraction(&self.data_dir) {
            Ok(fraction) if fraction <= self.max_disk_use_fraction => None,
            Ok(fraction) => {
                log::warn!(
                    "refusing an image: the data partition is {:.1} % full (the limit is {:.1} %)",
                    fraction * 100.0,
                    self.max_disk_use_fraction * 100.0
                );
                Some(status::OUT_OF_RESOURCES)
            }
            Err(error) => {
                log::error!("cannot tell how full the data partition is: {error}");
                Some(status::OUT_OF_RESOURCES)
            }
        }
    }

    /// A new file in the staging folder holding the preamble and file meta group.
    fn open_file(
        &mut self,
        command: &Command,
        context_id: u8,
    ) -> std::io::Result<(std::io::BufWriter<std::fs::File>, PathBuf)> {
        let transfer_syntax = self.contexts.iter().find(|(id, _, _)| *id == context_id).map(|c| c.2.clone());
        let meta = FileMetaTableBuilder::new()
            .media_storage_sop_class_uid(command.affected_sop_class.as_str())
            .media_storage_sop_instance_uid(command.affected_sop_instance.as_str())
            .transfer_syntax(transfer_syntax.unwrap_or_default())
            .build()
            .map_err(std::io::Error::other)?;
        let path = self.folder.join(format!("incoming-{}.dcm", self.next_file));
        self.next_file += 1;
        let mut writer = std::io::BufWriter::new(std::fs::File::create_new(&path)?);
        writer.write_all(&[0u8; 128])?;
        writer.write_all(b"DICM")?;
        meta.write(&mut writer).map_err(std::io::Error::other)?;
        Ok((writer, path))
    }

    /// Closes a received file, checks it and files it under its series; the status to answer.
    fn finish(
        &mut self,
        file: Option<(std::io::BufWriter<std::fs::File>, PathBuf)>,
        refused: u16,
        command: &Command,
    ) -> u16 {
        let Some((writer, path)) = file else { return refused };
        let flushed = writer.into_inner().map_err(|error| error.into_error()).and_then(|file| file.sync_all());
        if let Err(error) = flushed {
            log::error!("cannot write a received image: {error}");
            remove_path(&path);
            return status::PROCESSING_FAILURE;
        }
        let identity = match crate::volume::dicom::read_identity(&path, &self.limits) {
            Ok(identity) => identity,
            Err(error) => {
                log::warn!("refused an image that cannot be read: {error}");
                remove_path(&path);
                return status::CANNOT_UNDERSTAND;
            }
        };
        if identity.series_uid.is_empty()
            || identity.sop_instance_uid != command.affected_sop_instance
            || identity.sop_class_uid != command.affected_sop_class
        {
            log::warn!("refused an image whose SOP class, SOP instance or series does not match its command");
            remove_path(&path);
            return status::DATA_SET_DOES_NOT_MATCH;
        }
        let series = self.folder.join(series_name(&identity.modality, &identity.series_uid));
        let target = series.join(format!("{}.dcm", short_hash(&identity.sop_instance_uid)));
        let filed = std::fs::create_dir_all(&series).and_then(|()| std::fs::rename(&path, &target));
        if let Err(error) = filed {
            log::error!("cannot file a received image: {error}");
            remove_path(&path);
            return status::PROCESSING_FAILURE;
        }
        let image =
            ReceivedImage { series_uid: identity.series_uid, modality: identity.modality, path: target.clone() };
        self.received.insert(target, image);
        status::SUCCESS
    }
}

/// A response command in one P-DATA PDU.
fn respond(context_id: u8, request: &Command, status: u16) -> Pdu {
    Pdu::PData {
        data: vec![PDataValue {
            presentation_context_id: context_id,
            value_type: PDataValueType::Command,
            is_last: true,
            data: dimse::response(request, status),
        }],
    }
}
