//! One connection, from TLS handshake and negotiation to release or abort (PS3.8 upper layer
//! through dicom-ul, PS3.7 DIMSE on top).
//!
//! Each C-STORE's data set is streamed to its own file in the association's incoming folder as
//! its P-DATA fragments arrive (preamble, a file meta group built from the command and the
//! presentation context, then the data set bytes exactly as sent), so memory stays at one PDU
//! whatever the series' length. When the last fragment is written the file is flushed to disk
//! and read back as the kiosk reads it: its identity ([`volasso_core::volume::dicom::read_identity`])
//! and its pixel data (every frame decoded, [`volasso_core::volume::dicom::check_source`]). A data set
//! that fails is answered with a failure status and an Error Comment and removed; one that
//! passes is filed durably under its pending series ([`Store::accept`]) and only then answered
//! with success ([`super::dimse::status`] lists which status answers what).
//!
//! Publishing is not this module's: an association only tells the [`Tracker`] what arrived
//! and how it ended. Deadlines are the [`Watchdog`]'s: the ACSE timeout from the connection
//! to the negotiated association, then the idle timeout between PDUs, and the association's
//! overall deadline throughout.
//!
//! Never: logs or prints patient data, names a file after DICOM text, or answers success for
//! a data set that is not durably stored and readable.

use super::dimse::{self, Command, status};
use super::stable::{Tracker, print_reports};
use super::store::{Store, remove_path, used_fraction};
use super::watchdog::{Deadline, Watchdog};
use super::{ReceiveOptions, admission};
use dicom_object::FileMetaTableBuilder;
use dicom_ul::Pdu;
use dicom_ul::association::server::ServerAssociationOptions;
use dicom_ul::association::{Association, CloseSocket, ServerAssociation};
use dicom_ul::pdu::{
    AssociationRJ, AssociationRJResult, AssociationRJServiceUserReason, AssociationRJSource, PDataValue,
    PDataValueType, UserIdentity,
};
use std::collections::BTreeSet;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use volasso_core::volume::dicom::{self, DicomOptions};
use volasso_core::volume::limits::ReadLimits;

/// The largest PDU this SCP accepts; the sender splits data sets into PDUs of this size.
pub const MAX_PDU_BYTES: u32 = 64 * 1024;
/// A command set is a few hundred bytes; more is not a command.
const MOST_COMMAND_BYTES: usize = 64 * 1024;

/// Who may store: the called AE title must be ours, the calling one in the list (any when the
/// list is empty).
pub struct AllowedTitles {
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

/// What every connection shares.
pub struct Context {
    pub options: ReceiveOptions,
    pub store: Arc<Store>,
    pub tracker: Arc<Tracker>,
    pub watchdog: Watchdog,
    pub output: Arc<Mutex<dyn Write + Send>>,
    pub tls: Option<Arc<rustls::ServerConfig>>,
    negotiation: ServerAssociationOptions<'static, AllowedTitles, dicom_ul::association::server::DefaultNegotiation>,
}

impl Context {
    pub fn new(
        options: ReceiveOptions,
        store: Arc<Store>,
        tracker: Arc<Tracker>,
        watchdog: Watchdog,
        output: Arc<Mutex<dyn Write + Send>>,
        tls: Option<Arc<rustls::ServerConfig>>,
    ) -> Context {
        let mut negotiation = ServerAssociationOptions::new()
            .ae_access_control(AllowedTitles { calling: options.allowed_calling_ae.clone() })
            .ae_title(options.ae_title.clone())
            .max_pdu_length(MAX_PDU_BYTES)
            .read_timeout(options.timeouts.idle)
            .write_timeout(options.timeouts.idle)
            .with_abstract_syntax(dimse::VERIFICATION);
        for sop_class in dimse::STORAGE_SOP_CLASSES {
            negotiation = negotiation.with_abstract_syntax(sop_class);
        }
        for syntax in super::accepted_transfer_syntaxes() {
            negotiation = negotiation.with_transfer_syntax(syntax);
        }
        if let Some(config) = &tls {
            negotiation = negotiation.tls_config(Arc::clone(config));
        }
        Context { options, store, tracker, watchdog, output, tls, negotiation }
    }
}

/// How a connection ended.
#[derive(Debug)]
pub enum Outcome {
    /// Released normally.
    Released,
    /// Refused before an association was made (wrong AE title, nothing acceptable, a failed
    /// TLS handshake, a plain connection to the TLS port, no request in time).
    Refused(String),
    /// Aborted, broken or timed out after negotiation.
    Dropped(String),
}

/// Serves one connection: negotiation (over TLS when configured), then the association.
pub fn serve(stream: TcpStream, context: &Context) -> Outcome {
    let started = Instant::now();
    let timeouts = &context.options.timeouts;
    let overall = started + timeouts.association;
    let deadline = match context.watchdog.watch(&stream, (started + timeouts.acse).min(overall)) {
        Ok(deadline) => deadline,
        Err(error) => return Outcome::Refused(format!("cannot watch the connection ({error})")),
    };
    let timed_out = |deadline: &Deadline, what: String| {
        if deadline.expired() { format!("{what}: timed out") } else { what }
    };
    // The first byte tells a TLS ClientHello (a handshake record, 0x16) from a plain
    // A-ASSOCIATE-RQ (0x01); on the TLS port the latter is answered with a rejection instead
    // of TLS garbage.
    let mut first = [0u8; 1];
    let tls = context.tls.is_some();
    match stream.peek(&mut first) {
        Ok(1) if !tls || first[0] != 0x01 => {
            if let Err(problem) = wait_for_first_message(&stream, tls, &deadline) {
                return Outcome::Refused(timed_out(&deadline, problem));
            }
            let established = match tls {
                false => context
                    .negotiation
                    .establish(stream)
                    .map(|association| serve_association(association, context, &deadline, overall)),
                true => context
                    .negotiation
                    .establish_tls(stream)
                    .map(|association| serve_association(association, context, &deadline, overall)),
            };
            established.unwrap_or_else(|error| Outcome::Refused(timed_out(&deadline, error.to_string())))
        }
        Ok(1) => {
            let rejection = Pdu::AssociationRJ(AssociationRJ {
                result: AssociationRJResult::Permanent,
                source: AssociationRJSource::ServiceUser(AssociationRJServiceUserReason::NoReasonGiven),
            });
            let mut bytes = Vec::new();
            let _ = dicom_ul::write_pdu(&mut bytes, &rejection);
            admission::answer_and_close(stream, Some, &bytes);
            Outcome::Refused("a plain (not TLS) association request on the TLS port".into())
        }
        Ok(_) => Outcome::Refused("the connection ended before a request".into()),
        Err(error) => Outcome::Refused(timed_out(&deadline, error.to_string())),
    }
}

/// The most bytes a first message (an A-ASSOCIATE-RQ, or a ClientHello's records) may take.
const MOST_FIRST_MESSAGE_BYTES: usize = MAX_PDU_BYTES as usize + 6;

/// How much of a peer's first message has arrived.
#[derive(Debug, PartialEq, Eq)]
enum FirstMessage {
    /// All of it.
    Whole,
    /// At least this many bytes are needed.
    Needs(usize),
    /// It is not what this port speaks, or too long.
    Invalid(&'static str),
}

/// How much of the first message `bytes` begin (an A-ASSOCIATE-RQ PDU, or with `tls` the TLS
/// records of a ClientHello).
fn first_message(bytes: &[u8], tls: bool) -> FirstMessage {
    if !tls {
        if bytes.len() < 6 {
            return FirstMessage::Needs(6);
        }
        if bytes[0] != 0x01 {
            return FirstMessage::Invalid(match bytes[0] {
                0x16 => "a TLS handshake on a port without TLS",
                _ => "a first PDU that is not an A-ASSOCIATE-RQ",
            });
        }
        let length = u32::from_be_bytes([bytes[2], bytes[3], bytes[4], bytes[5]]) as usize;
        return match 6 + length {
            total if total > MOST_FIRST_MESSAGE_BYTES => FirstMessage::Invalid("an A-ASSOCIATE-RQ that is too long"),
            total if bytes.len() >= total => FirstMessage::Whole,
            total => FirstMessage::Needs(total),
        };
    }
    // Handshake records (type 22, version, 16-bit length, payload) whose payloads, joined,
    // hold a ClientHello (type 1, 24-bit length) whole.
    let (mut offset, mut payload) = (0, Vec::new());
    loop {
        if bytes.len() < offset + 5 {
            return FirstMessage::Needs(offset + 5);
        }
        if bytes[offset] != 0x16 {
            return FirstMessage::Invalid("a first TLS record that is not a handshake");
        }
        let end = offset + 5 + usize::from(u16::from_be_bytes([bytes[offset + 3], bytes[offset + 4]]));
        if end > MOST_FIRST_MESSAGE_BYTES {
            return FirstMessage::Invalid("a ClientHello that is too long");
        }
        if bytes.len() < end {
            return FirstMessage::Needs(end);
        }
        payload.extend_from_slice(&bytes[offset + 5..end]);
        offset = end;
        if payload.len() >= 4 {
            if payload[0] != 0x01 {
                return FirstMessage::Invalid("a first TLS handshake message that is not a ClientHello");
            }
            let length = u32::from_be_bytes([0, payload[1], payload[2], payload[3]]) as usize;
            if payload.len() >= 4 + length {
                return FirstMessage::Whole;
            }
        }
    }
}

/// Waits (within the connection's deadline, which shuts the socket) until the peer's first
/// message has arrived whole, without reading it. dicom-ul's negotiation must only ever start
/// then: its TLS detection (built in with TLS support, for plain ports too) loops forever on
/// a connection that ends before a whole message.
fn wait_for_first_message(stream: &TcpStream, tls: bool, deadline: &Deadline) -> Result<(), String> {
    let mut buffer = vec![0u8; 64];
    loop {
        if deadline.expired() {
            return Err("no whole request in time".into());
        }
        let available = stream.peek(&mut buffer).map_err(|error| format!("cannot read the request ({error})"))?;
        if available == 0 {
            return Err("the connection ended before a whole request".into());
        }
        match first_message(&buffer[..available], tls) {
            FirstMessage::Whole => return Ok(()),
            FirstMessage::Invalid(problem) => return Err(problem.into()),
            FirstMessage::Needs(total) if total > buffer.len() => buffer.resize(total, 0),
            // Part of it is there: the rest is waited for in short steps (a peek returns at
            // once while unread bytes wait, even after the peer closed).
            FirstMessage::Needs(_) if peer_closed(stream) => {
                return Err("the connection ended in the middle of the request".into());
            }
            FirstMessage::Needs(_) => std::thread::sleep(std::time::Duration::from_millis(10)),
        }
    }
}

/// Whether the peer has closed its side of `stream` (or it failed), unread bytes or not.
fn peer_closed(stream: &TcpStream) -> bool {
    use std::os::fd::AsRawFd;
    let mut poll = libc::pollfd { fd: stream.as_raw_fd(), events: libc::POLLRDHUP, revents: 0 };
    // SAFETY: one pollfd, valid for the call; a zero timeout never blocks.
    let ready = unsafe { libc::poll(&mut poll, 1, 0) };
    ready < 0 || poll.revents & (libc::POLLRDHUP | libc::POLLHUP | libc::POLLERR) != 0
}

/// Serves a negotiated association until it is released, aborted, broken or timed out.
fn serve_association<S>(
    mut association: ServerAssociation<S>,
    context: &Context,
    deadline: &Deadline,
    overall: Instant,
) -> Outcome
where
    S: Read + Write + CloseSocket,
{
    let idle = context.options.timeouts.idle;
    deadline.set((Instant::now() + idle).min(overall));
    let calling_ae = association.peer_ae_title().trim().to_string();
    let folder = match context.store.association_folder() {
        Ok(folder) => folder,
        Err(error) => {
            let _ = association.abort();
            return Outcome::Dropped(format!("cannot create a folder for incoming images ({error})"));
        }
    };
    let contexts: Vec<(u8, String, String)> = association
        .presentation_contexts()
        .iter()
        .map(|context| (context.id, context.abstract_syntax.clone(), context.transfer_syntax.clone()))
        .collect();
    let mut session = Session::new(folder.clone(), context, contexts, calling_ae);
    let ended = loop {
        let pdu = match association.receive() {
            Ok(pdu) => pdu,
            Err(error) if deadline.expired() => {
                break Err(format!("timed out (no PDU for {idle:?}, or past the association's deadline; {error})"));
            }
            Err(error) => break Err(format!("the connection ended without a release ({error})")),
        };
        deadline.set((Instant::now() + idle).min(overall));
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
    remove_path(&folder);
    let ended = match ended {
        Ok(()) if session.current.is_some() => Err("released in the middle of a data set".to_string()),
        ended => ended,
    };
    let series: Vec<String> = session.series.into_iter().collect();
    let reports = context.tracker.ended(&series, ended.as_ref().err().map(String::as_str));
    print_reports(&context.output, &reports);
    match ended {
        Ok(()) => Outcome::Released,
        Err(problem) => Outcome::Dropped(problem),
    }
}

/// The image being received: its command and its file (none when it is being refused).
struct Incoming {
    command: Command,
    context_id: u8,
    file: Option<(std::io::BufWriter<std::fs::File>, PathBuf)>,
    /// The status to answer with when the data set ends, and its Error Comment: success
    /// unless refused up front.
    status: (u16, Option<String>),
}

/// The state of one association between PDUs.
struct Session<'a> {
    folder: PathBuf,
    context: &'a Context,
    /// (presentation context id, abstract syntax, transfer syntax) of accepted contexts.
    contexts: Vec<(u8, String, String)>,
    calling_ae: String,
    command_bytes: Vec<u8>,
    current: Option<Incoming>,
    /// The series (folder names) this association sent images of.
    series: BTreeSet<String>,
    next_file: u64,
    limits: ReadLimits,
}

impl<'a> Session<'a> {
    fn new(folder: PathBuf, context: &'a Context, contexts: Vec<(u8, String, String)>, calling_ae: String) -> Self {
        Session {
            folder,
            context,
            contexts,
            calling_ae,
            command_bytes: Vec::new(),
            current: None,
            series: BTreeSet::new(),
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
                let written = match incoming.file.as_mut() {
                    Some((writer, _)) => writer.write_all(&value.data),
                    None => Ok(()),
                };
                if let Err(error) = written {
                    log::error!("cannot write a received image: {error}");
                    if let Some((_, path)) = incoming.file.take() {
                        remove_path(&path);
                    }
                    incoming.status = (status::PROCESSING_FAILURE, Some(format!("cannot write the image: {error}")));
                }
                if !value.is_last {
                    return Ok(None);
                }
                let incoming = self.current.take().ok_or("no data set in progress")?;
                let (status, comment) = match incoming.file {
                    Some(file) => self.finish(file, &incoming.command),
                    None => incoming.status,
                };
                Ok(Some(respond(incoming.context_id, &incoming.command, status, comment.as_deref())))
            }
        }
    }

    fn command(&mut self, command: Command, context_id: u8) -> Result<Option<Pdu>, String> {
        match command.field {
            dimse::C_ECHO_RQ => Ok(Some(respond(context_id, &command, status::SUCCESS, None))),
            dimse::C_STORE_RQ if command.has_data_set => {
                let mut status = self.refusal(&command, context_id).unwrap_or((status::SUCCESS, None));
                let mut file = None;
                if status.0 == status::SUCCESS {
                    match self.open_file(&command, context_id) {
                        Ok(opened) => file = Some(opened),
                        Err(error) => {
                            log::error!("cannot create a file for a received image: {error}");
                            status = (status::PROCESSING_FAILURE, Some(format!("cannot create a file: {error}")));
                        }
                    }
                }
                self.current = Some(Incoming { command, context_id, file, status });
                Ok(None)
            }
            dimse::C_STORE_RQ => {
                let comment = Some("a C-STORE request without a data set");
                Ok(Some(respond(context_id, &command, status::CANNOT_UNDERSTAND, comment)))
            }
            other => Err(format!("a DIMSE command this SCP does not serve (CommandField {other:#06x})")),
        }
    }

    /// Why a C-STORE is refused before its data arrives: a SOP class other than the context's
    /// or not a CT/MR image, or a data partition fuller than allowed.
    fn refusal(&self, command: &Command, context_id: u8) -> Option<(u16, Option<String>)> {
        let context = self.contexts.iter().find(|(id, _, _)| *id == context_id);
        let sop_class_fits = context.is_some_and(|(_, abstract_syntax, _)| {
            abstract_syntax == &command.affected_sop_class
                && dimse::STORAGE_SOP_CLASSES.contains(&command.affected_sop_class.as_str())
        });
        if !sop_class_fits {
            return Some((status::SOP_CLASS_NOT_SUPPORTED, Some("SOP class not accepted on this context".into())));
        }
        let limit = self.context.options.max_disk_use_fraction;
        match used_fraction(self.context.store.data_dir()) {
            Ok(fraction) if fraction <= limit => None,
            Ok(fraction) => {
                log::warn!(
                    "refusing an image: the data partition is {:.1} % full (the limit is {:.1} %)",
                    fraction * 100.0,
                    limit * 100.0
                );
                Some((status::OUT_OF_RESOURCES, Some(format!("the receiver's disk is {:.0} % full", fraction * 100.0))))
            }
            Err(error) => {
                log::error!("cannot tell how full the data partition is: {error}");
                Some((status::OUT_OF_RESOURCES, Some("cannot tell how full the receiver's disk is".into())))
            }
        }
    }

    /// A new file in the incoming folder holding the preamble and file meta group.
    fn open_file(
        &mut self,
        command: &Command,
        context_id: u8,
    ) -> std::io::Result<(std::io::BufWriter<std::fs::File>, PathBuf)> {
        let transfer_syntax = self.contexts.iter().find(|(id, _, _)| *id == context_id).map(|c| c.2.clone());
        let meta = FileMetaTableBuilder::new()
            .media_storage_sop_class_uid(command.affected_sop_class.as_str())
            .media_storage_sop_instance_uid(meta_uid(&command.affected_sop_instance))
            .transfer_syntax(transfer_syntax.unwrap_or_default())
            .build()
            .map_err(std::io::Error::other)?;
        let path = self.folder.join(format!("{}.dcm", self.next_file));
        self.next_file += 1;
        let mut writer = std::io::BufWriter::new(std::fs::File::create_new(&path)?);
        writer.write_all(&[0u8; 128])?;
        writer.write_all(b"DICM")?;
        meta.write(&mut writer).map_err(std::io::Error::other)?;
        Ok((writer, path))
    }

    /// Closes a received file, checks it as the kiosk reads it and files it durably under its
    /// series; the status (and Error Comment) to answer with.
    fn finish(
        &mut self,
        (writer, path): (std::io::BufWriter<std::fs::File>, PathBuf),
        command: &Command,
    ) -> (u16, Option<String>) {
        let flushed = writer.into_inner().map_err(|error| error.into_error()).and_then(|file| file.sync_all());
        if let Err(error) = flushed {
            log::error!("cannot write a received image: {error}");
            remove_path(&path);
            return (status::PROCESSING_FAILURE, Some(format!("cannot write the image: {error}")));
        }
        let refuse = |status: u16, problem: String| {
            log::warn!("refused an image ({status:#06x}): {problem}");
            remove_path(&path);
            (status, Some(problem))
        };
        let identity = match dicom::read_identity(&path, &self.limits) {
            Ok(identity) => identity,
            Err(error) => return refuse(status::CANNOT_UNDERSTAND, without_path(&error.to_string(), &path)),
        };
        if identity.series_uid.is_empty() {
            return refuse(status::CANNOT_UNDERSTAND, "no Series Instance UID".into());
        }
        if identity.sop_instance_uid != command.affected_sop_instance
            || identity.sop_class_uid != command.affected_sop_class
        {
            return refuse(
                status::DATA_SET_DOES_NOT_MATCH,
                "SOP Class or Instance UID differs from the request's".into(),
            );
        }
        if let Err(error) = readable(&path, &self.limits) {
            return refuse(status::CANNOT_UNDERSTAND, without_path(&error.to_string(), &path));
        }
        let store = &self.context.store;
        let accepted = match store.accept(&path, &identity.modality, &identity.series_uid, &identity.sop_instance_uid) {
            Ok(accepted) => accepted,
            Err(error) => {
                log::error!("cannot store a received image: {error}");
                remove_path(&path);
                return (status::PROCESSING_FAILURE, Some(format!("cannot store the image: {error}")));
            }
        };
        let first = self.series.insert(accepted.name.clone());
        self.context.tracker.arrived(&accepted, &identity.series_uid, first, &self.calling_ae);
        (status::SUCCESS, None)
    }
}

/// Whether the kiosk can read the image in `path` on its own: header, geometry and every
/// frame's pixel data decoded.
fn readable(path: &Path, limits: &ReadLimits) -> Result<(), volasso_core::volume::VolumeError> {
    let source = dicom::list_source(path, limits)?;
    dicom::check_source(path, &source, &DicomOptions::default(), limits).map(|_| ())
}

/// The Media Storage SOP Instance UID written to a received file's meta group: the instance's
/// own UID, or, when that is not a UID (letters, say, which some archives write and which the
/// file meta reader refuses), one derived from its SHA-256 in the `2.25.` form (PS3.5 §B.2).
/// The data set keeps its own SOP Instance UID; only the meta group's copy differs.
fn meta_uid(uid: &str) -> String {
    let valid = !uid.is_empty() && uid.len() <= 64 && uid.bytes().all(|byte| byte.is_ascii_digit() || byte == b'.');
    if valid {
        return uid.to_string();
    }
    let digest = <sha2::Sha256 as sha2::Digest>::digest(uid.as_bytes());
    let mut number = [0u8; 16];
    number.copy_from_slice(&digest[..16]);
    format!("2.25.{}", u128::from_be_bytes(number))
}

/// A reader's error without the incoming file's path (which means nothing to the sender).
fn without_path(message: &str, path: &Path) -> String {
    let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let mut message = message.to_string();
    for shown in [canonical.display().to_string(), path.display().to_string()] {
        message = message.replace(&format!(", in {shown}"), "").replace(&shown, "the data set");
    }
    message
}

/// A response command in one P-DATA PDU.
fn respond(context_id: u8, request: &Command, status: u16, comment: Option<&str>) -> Pdu {
    Pdu::PData {
        data: vec![PDataValue {
            presentation_context_id: context_id,
            value_type: PDataValueType::Command,
            is_last: true,
            data: dimse::response(request, status, comment),
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sop_instance_uid_that_is_not_a_uid_gets_a_valid_one_in_the_meta_group() {
        assert_eq!(meta_uid("1.2.840.113619.2.1"), "1.2.840.113619.2.1");
        let odd = "dccc9599087131742838cc1162a630fea87ba9bf61ac09bfda90d4adfa5ddaed";
        let derived = meta_uid(odd);
        assert!(derived.starts_with("2.25.") && derived.len() <= 64, "{derived}");
        assert!(derived[5..].bytes().all(|byte| byte.is_ascii_digit()), "{derived}");
        assert_eq!(meta_uid(odd), derived);
        assert_ne!(meta_uid("1.2.3x"), derived);
        assert!(meta_uid("").starts_with("2.25."));
    }

    #[test]
    fn a_first_message_is_whole_only_when_all_its_bytes_are_there() {
        let request = [0x01, 0, 0, 0, 0, 3, 7, 7, 7];
        assert_eq!(first_message(&request[..2], false), FirstMessage::Needs(6));
        assert_eq!(first_message(&request[..7], false), FirstMessage::Needs(9));
        assert_eq!(first_message(&request, false), FirstMessage::Whole);
        assert!(matches!(first_message(&[0x16, 3, 1, 0, 5, 1], false), FirstMessage::Invalid(_)));
        assert!(matches!(first_message(&[0x01, 0, 0xFF, 0, 0, 0], false), FirstMessage::Invalid(_)));
        // A ClientHello of 6 bytes (4 of header, 2 of body) split over two records.
        let hello = [0x16, 3, 1, 0, 3, 0x01, 0, 0, 0x16, 3, 1, 0, 3, 2, 9, 9];
        assert_eq!(first_message(&hello[..4], true), FirstMessage::Needs(5));
        assert_eq!(first_message(&hello[..8], true), FirstMessage::Needs(13));
        assert_eq!(first_message(&hello[..13], true), FirstMessage::Needs(16));
        assert_eq!(first_message(&hello, true), FirstMessage::Whole);
        assert!(matches!(first_message(&[0x17, 3, 1, 0, 1, 0], true), FirstMessage::Invalid(_)));
        assert!(matches!(first_message(&[0x16, 3, 1, 0, 4, 0x02, 0, 0, 0], true), FirstMessage::Invalid(_)));
    }

    #[test]
    fn errors_name_the_data_set_not_the_incoming_file() {
        let path = Path::new("/data/.volasso-receive/incoming/1-0/3.dcm");
        let message = format!("DICOM: PixelData is short, in {}", path.display());
        assert_eq!(without_path(&message, path), "DICOM: PixelData is short");
    }
}
