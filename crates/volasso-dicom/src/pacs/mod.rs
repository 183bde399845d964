//! `volasso pacs`: the kiosk as a DICOM client of a PACS (`interfaces.md`, "pacs";
//! `docs/conformance.md`): C-FIND at study level with each study's series (`find.rs`), C-GET
//! of a study or series into the data folder, published as a received series is (`get.rs`,
//! through [`crate::receive`]'s store), and C-STORE of files such as those `volasso export`
//! writes (`send.rs`), each file in its own transfer syntax where the PACS accepts it. The
//! upper layer, association negotiation and PDUs are dicom-ul's; command sets and identifiers
//! are dicom-object data sets.
//!
//! Every association has a connection, read and write timeout ([`Peer::timeout`]); a PACS that
//! is down, rejects the association, accepts none of the contexts or answers a failure status
//! is one [`PacsError`].
//!
//! Never: prints or logs a patient's name or ID, reports a file as stored before the PACS
//! answered its C-STORE with success (or a warning), publishes a retrieved series that does not
//! import cleanly, or keeps an association open after the command.

mod find;
mod get;
mod moving;
mod send;

pub use find::{FindQuery, SeriesFound, StudyFound, find};
pub use get::{get, get_counting};
pub use moving::RECEIVER_PATIENCE;
pub use send::{SendReport, send};

use dicom_core::{DataElement, PrimitiveValue, VR, dicom_value};
use dicom_dictionary_std::tags;
use dicom_encoding::TransferSyntaxIndex;
use dicom_object::InMemDicomObject;
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;
use dicom_transfer_syntax_registry::entries::IMPLICIT_VR_LITTLE_ENDIAN;
use dicom_ul::association::client::ClientAssociationOptions;
use dicom_ul::pdu::{PDataValue, PDataValueType};
use dicom_ul::{ClientAssociation, Pdu};
use std::io::Write;
use std::net::TcpStream;
use std::time::Duration;

/// The most bytes of one command set accepted from a peer.
const MOST_COMMAND_BYTES: usize = 64 * 1024;
/// The most bytes of one C-FIND identifier accepted from a peer.
const MOST_IDENTIFIER_BYTES: usize = 1024 * 1024;

/// The TLS configuration of a PACS client ([`crate::receive::tls::client_config`]).
pub type TlsConfig = std::sync::Arc<rustls::ClientConfig>;

/// A PACS: its AE title and address, and this client's own title.
#[derive(Clone, Debug)]
pub struct Peer {
    /// The PACS's AE title (the called AE title).
    pub ae_title: String,
    /// Host name or address.
    pub host: String,
    /// TCP port.
    pub port: u16,
    /// This kiosk's AE title (the calling AE title).
    pub calling_ae_title: String,
    /// Bounds the connection, each read and each write.
    pub timeout: Duration,
    /// DICOM over TLS (`--tls-ca`, PS3.15 Annex B.9 as [`crate::receive::tls`] describes it);
    /// `None`: plain TCP.
    pub tls: Option<TlsConfig>,
}

/// Peers are the same PACS when they have the same titles, address and timeout, and both or
/// neither use TLS.
impl PartialEq for Peer {
    fn eq(&self, other: &Peer) -> bool {
        (&self.ae_title, &self.host, self.port, &self.calling_ae_title, self.timeout, self.tls.is_some())
            == (&other.ae_title, &other.host, other.port, &other.calling_ae_title, other.timeout, other.tls.is_some())
    }
}

impl Eq for Peer {}

/// An association over plain TCP or TLS: the few calls this client makes, on either.
pub(super) enum Association {
    Plain(ClientAssociation<TcpStream>),
    Tls(Box<ClientAssociation<dicom_ul::association::client::TlsStream>>),
}

/// `$body` with `$association` bound to the inner association, whichever it is.
macro_rules! on_either {
    ($self:expr, $association:ident => $body:expr) => {
        match $self {
            Association::Plain($association) => $body,
            Association::Tls($association) => $body,
        }
    };
}

impl Association {
    /// The presentation context the PACS accepted for `abstract_syntax`: its ID and transfer
    /// syntax.
    fn context_for(&self, abstract_syntax: &str) -> Option<(u8, String)> {
        self.presentation_contexts()
            .iter()
            .find(|context| context.abstract_syntax == abstract_syntax)
            .map(|context| (context.id, context.transfer_syntax.clone()))
    }

    fn presentation_contexts(&self) -> &[dicom_ul::pdu::PresentationContextNegotiated] {
        on_either!(self, association => association.presentation_contexts())
    }

    fn read_timeout(&self) -> Option<Duration> {
        on_either!(self, association => association.read_timeout())
    }

    fn send(&mut self, pdu: &Pdu) -> Result<(), dicom_ul::association::Error> {
        on_either!(self, association => association.send(pdu))
    }

    fn receive(&mut self) -> Result<Pdu, dicom_ul::association::Error> {
        on_either!(self, association => association.receive())
    }

    /// Sends `data` as the data set of a message on presentation context `context`.
    fn send_data(&mut self, context: u8, data: &[u8]) -> std::io::Result<()> {
        on_either!(self, association => {
            let mut writer = association.send_pdata(context);
            writer.write_all(data)?;
            writer.finish()
        })
    }

    fn release(self) -> Result<(), dicom_ul::association::Error> {
        on_either!(self, association => association.release())
    }

    fn abort(self) -> Result<(), dicom_ul::association::Error> {
        on_either!(self, association => association.abort())
    }
}

impl Peer {
    /// Parses `AE@host:port` (an IPv6 host in brackets).
    pub fn parse(text: &str, calling_ae_title: &str, timeout: Duration) -> Result<Peer, PacsError> {
        let bad = |problem: &'static str| PacsError::Address { text: text.to_string(), problem };
        let (ae_title, address) = text.split_once('@').ok_or_else(|| bad("is not AE@host:port"))?;
        let (host, port) = address.rsplit_once(':').ok_or_else(|| bad("has no :port"))?;
        let port: u16 = port.parse().ok().filter(|&port| port > 0).ok_or_else(|| bad("has no port from 1 to 65535"))?;
        let host = host.trim_start_matches('[').trim_end_matches(']');
        if host.is_empty() {
            return Err(bad("has no host"));
        }
        for title in [ae_title, calling_ae_title] {
            crate::receive::check_ae_title(title).map_err(|error| PacsError::AeTitle { problem: error.to_string() })?;
        }
        Ok(Peer {
            ae_title: ae_title.to_string(),
            host: host.to_string(),
            port,
            calling_ae_title: calling_ae_title.to_string(),
            timeout,
            tls: None,
        })
    }

    /// `AE@host:port`, as given.
    pub fn describe(&self) -> String {
        format!("{}@{}:{}", self.ae_title, self.host, self.port)
    }

    /// Opens an association proposing `contexts` (abstract syntax, transfer syntaxes) and, for
    /// the abstract syntaxes in `scp_roles`, the SCP role (C-GET's storage sub-operations).
    fn associate(&self, contexts: &[(String, Vec<String>)], scp_roles: &[&str]) -> Result<Association, PacsError> {
        let mut options = ClientAssociationOptions::new()
            .calling_ae_title(self.calling_ae_title.as_str())
            .called_ae_title(self.ae_title.as_str())
            .max_pdu_length(65_536)
            .connection_timeout(self.timeout)
            .read_timeout(self.timeout)
            .write_timeout(self.timeout);
        for (abstract_syntax, transfer_syntaxes) in contexts {
            options = options.with_presentation_context(abstract_syntax.clone(), transfer_syntaxes.clone());
        }
        for sop_class in scp_roles {
            options = options.with_role_selection(*sop_class, false, true);
        }
        let started = std::time::Instant::now();
        let address = (self.host.as_str(), self.port);
        let established = match &self.tls {
            None => options.establish(address).map(Association::Plain),
            Some(config) => options
                .tls_config(config.clone())
                .server_name(self.host.as_str())
                .establish_tls(address)
                .map(|association| Association::Tls(Box::new(association))),
        };
        established.map_err(|error| PacsError::Association {
            peer: self.describe(),
            problem: timed_out(started, Some(self.timeout), "answer the association request")
                .unwrap_or_else(|| chain(&error)),
        })
    }
}

/// Why a PACS operation failed.
#[derive(Debug, thiserror::Error)]
pub enum PacsError {
    /// `--pacs` is not `AE@host:port`.
    #[error("--pacs {text:?} {problem}")]
    Address {
        /// The text given.
        text: String,
        /// What is wrong with it.
        problem: &'static str,
    },
    /// The TLS files cannot make a client configuration.
    #[error("DICOM over TLS: {0}")]
    Tls(#[from] crate::receive::tls::TlsError),
    /// An AE title breaks DICOM's rules.
    #[error("{problem}")]
    AeTitle {
        /// The rule and title.
        problem: String,
    },
    /// No association: the PACS is down, unreachable, rejected it, or accepted no context.
    #[error("no association with the PACS {peer}: {problem}")]
    Association {
        /// `AE@host:port`.
        peer: String,
        /// dicom-ul's account, causes included.
        problem: String,
    },
    /// The association broke or the PACS answered something that is not DIMSE.
    #[error("the association with the PACS {peer} failed: {problem}")]
    Protocol {
        /// `AE@host:port`.
        peer: String,
        /// What happened.
        problem: String,
    },
    /// The PACS answered a request with a failure status.
    #[error("the PACS {peer} answered the {operation} with status {status:04X}H{}", comment.as_ref().map(|c| format!(" ({c})")).unwrap_or_default())]
    Status {
        /// `AE@host:port`.
        peer: String,
        /// `C-FIND`, `C-GET`...
        operation: &'static str,
        /// The DIMSE status.
        status: u16,
        /// The Error Comment, when the PACS sent one.
        comment: Option<String>,
    },
    /// The data folder cannot be prepared or written.
    #[error("cannot write into the data folder: {source}, {}", path.display())]
    DataDir {
        /// The system's error.
        source: std::io::Error,
        /// The folder.
        path: std::path::PathBuf,
    },
    /// A file to send cannot be read as DICOM.
    #[error("cannot send {}: {problem}", path.display())]
    File {
        /// What is wrong with it.
        problem: String,
        /// The file.
        path: std::path::PathBuf,
    },
    /// Some files were not stored (each was reported on its own line).
    #[error("{failed} of {total} files were not stored by the PACS {peer}")]
    NotAllStored {
        /// Files not stored.
        failed: usize,
        /// Files given.
        total: usize,
        /// `AE@host:port`.
        peer: String,
    },
    /// The C-GET succeeded without a single image (an unknown UID, say).
    #[error("the C-GET from the PACS {peer} retrieved no image for {uid}")]
    NothingRetrieved {
        /// The study or series asked for.
        uid: String,
        /// `AE@host:port`.
        peer: String,
    },
    /// Some retrieved series were not published (each was reported on its own line).
    #[error("{failed} retrieved series could not be published (see their \"incomplete\" lines)")]
    NotAllPublished {
        /// Series not published.
        failed: usize,
    },
    /// The PACS answered a C-MOVE with success, but the kiosk's receiver did not publish the
    /// series in time.
    #[error(
        "the PACS {peer} sent the images to {destination}, but {missing} series did not appear in {} within {seconds} s (is volasso receive running there, and does the PACS know {destination}'s address?)",
        data_dir.display()
    )]
    ReceiverSilent {
        /// `AE@host:port`.
        peer: String,
        /// The move destination (this kiosk's AE title).
        destination: String,
        /// Series not published.
        missing: usize,
        /// How long the kiosk waited.
        seconds: u64,
        /// The data folder.
        data_dir: std::path::PathBuf,
    },
}

/// An error and its causes, one sentence.
fn chain(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        let cause_text = cause.to_string();
        if !text.contains(&cause_text) {
            text.push_str(": ");
            text.push_str(&cause_text);
        }
        source = cause.source();
    }
    text
}

/// "it did not WHAT within N s" when a call that started at `started` failed after the
/// timeout: dicom-ul reports a read timed out as other errors (data that look like TLS, say).
fn timed_out(started: std::time::Instant, timeout: Option<Duration>, what: &str) -> Option<String> {
    let timeout = timeout?;
    (started.elapsed() + Duration::from_millis(20) >= timeout)
        .then(|| format!("it did not {what} within {} s", timeout.as_secs_f64()))
}

/// Explicit and Implicit VR Little Endian: what command identifiers are proposed in.
fn native_syntaxes() -> Vec<String> {
    vec!["1.2.840.10008.1.2.1".to_string(), "1.2.840.10008.1.2".to_string()]
}

/// The identifier of a C-GET or C-MOVE: the study, or one series of it.
fn retrieve_identifier(study_uid: &str, series_uid: Option<&str>) -> InMemDicomObject {
    let level = if series_uid.is_some() { "SERIES" } else { "STUDY" };
    let mut identifier = InMemDicomObject::from_element_iter([
        DataElement::new(tags::QUERY_RETRIEVE_LEVEL, VR::CS, PrimitiveValue::from(level)),
        DataElement::new(tags::STUDY_INSTANCE_UID, VR::UI, PrimitiveValue::from(study_uid)),
    ]);
    if let Some(series_uid) = series_uid {
        identifier.put(DataElement::new(tags::SERIES_INSTANCE_UID, VR::UI, PrimitiveValue::from(series_uid)));
    }
    identifier
}

/// Priority MEDIUM.
fn priority() -> DataElement<InMemDicomObject> {
    DataElement::new(tags::PRIORITY, VR::US, dicom_value!(U16, [0]))
}

/// A request command set (PS3.7 §9.3): its fields and whether a data set follows.
fn command(
    field: u16,
    message_id: u16,
    sop_class: &str,
    extra: Vec<DataElement<InMemDicomObject>>,
    data: bool,
) -> Vec<u8> {
    let mut elements = vec![
        DataElement::new(tags::AFFECTED_SOP_CLASS_UID, VR::UI, PrimitiveValue::from(sop_class)),
        DataElement::new(tags::COMMAND_FIELD, VR::US, dicom_value!(U16, [field])),
        DataElement::new(tags::MESSAGE_ID, VR::US, dicom_value!(U16, [message_id])),
        DataElement::new(tags::COMMAND_DATA_SET_TYPE, VR::US, dicom_value!(U16, [if data { 0x0000 } else { 0x0101 }])),
    ];
    elements.extend(extra);
    let mut bytes = Vec::new();
    // A command set of a few short elements written into memory cannot fail.
    let _ = InMemDicomObject::command_from_element_iter(elements)
        .write_dataset_with_ts(&mut bytes, &IMPLICIT_VR_LITTLE_ENDIAN.erased());
    bytes
}

/// A data set encoded in `transfer_syntax` (a native one).
fn encode(object: &InMemDicomObject, transfer_syntax: &str) -> Result<Vec<u8>, String> {
    let syntax = TransferSyntaxRegistry
        .get(transfer_syntax)
        .ok_or_else(|| format!("unknown transfer syntax {transfer_syntax}"))?;
    let mut bytes = Vec::new();
    object.write_dataset_with_ts(&mut bytes, syntax).map_err(|error| error.to_string())?;
    Ok(bytes)
}

/// A data set read from bytes in `transfer_syntax`.
fn decode(bytes: &[u8], transfer_syntax: &str) -> Result<InMemDicomObject, String> {
    let syntax = TransferSyntaxRegistry
        .get(transfer_syntax)
        .ok_or_else(|| format!("unknown transfer syntax {transfer_syntax}"))?;
    InMemDicomObject::read_dataset_with_ts(bytes, syntax).map_err(|error| error.to_string())
}

/// Sends a command (and its data set) on presentation context `context`.
fn send_message(
    association: &mut Association,
    context: u8,
    command: Vec<u8>,
    data: Option<&[u8]>,
) -> Result<(), String> {
    association
        .send(&Pdu::PData {
            data: vec![PDataValue {
                presentation_context_id: context,
                value_type: PDataValueType::Command,
                is_last: true,
                data: command,
            }],
        })
        .map_err(|error| chain(&error))?;
    if let Some(data) = data {
        association.send_data(context, data).map_err(|error| error.to_string())?;
    }
    Ok(())
}

/// The fields of a message the peer sent that the client uses.
#[derive(Debug)]
struct Received {
    context: u8,
    field: u16,
    message_id: u16,
    status: u16,
    comment: Option<String>,
    sop_class: String,
    sop_instance: String,
    has_data: bool,
}

/// The next command set from the peer (fragments joined). A release request or an abort ends
/// with an error.
fn receive_command(association: &mut Association) -> Result<Received, String> {
    let mut bytes = Vec::new();
    loop {
        let started = std::time::Instant::now();
        let pdu = association.receive().map_err(|error| {
            timed_out(started, association.read_timeout(), "answer").unwrap_or_else(|| chain(&error))
        })?;
        match pdu {
            Pdu::PData { data } => {
                for value in data {
                    if value.value_type != PDataValueType::Command {
                        return Err("a data set arrived where a command was expected".into());
                    }
                    if bytes.len() + value.data.len() > MOST_COMMAND_BYTES {
                        return Err(format!("a command set longer than {MOST_COMMAND_BYTES} bytes"));
                    }
                    bytes.extend(&value.data);
                    if value.is_last {
                        return parse_received(&bytes, value.presentation_context_id);
                    }
                }
            }
            Pdu::AbortRQ { source } => return Err(format!("the PACS aborted the association ({source:?})")),
            Pdu::ReleaseRQ => return Err("the PACS released the association before answering".into()),
            other => return Err(format!("an unexpected PDU ({other:?})")),
        }
    }
}

fn parse_received(bytes: &[u8], context: u8) -> Result<Received, String> {
    let object = InMemDicomObject::read_dataset_with_ts(bytes, &IMPLICIT_VR_LITTLE_ENDIAN.erased())
        .map_err(|error| format!("a command set that cannot be read ({error})"))?;
    let number = |tag| object.get(tag).and_then(|element| element.to_int::<u16>().ok());
    let text = |tag| {
        object
            .get(tag)
            .and_then(|element| element.to_str().ok())
            .map(|text| text.trim_end_matches(['\0', ' ']).to_string())
    };
    Ok(Received {
        context,
        field: number(tags::COMMAND_FIELD).ok_or("a command set without a CommandField")?,
        message_id: number(tags::MESSAGE_ID).or(number(tags::MESSAGE_ID_BEING_RESPONDED_TO)).unwrap_or(0),
        status: number(tags::STATUS).unwrap_or(0),
        comment: text(tags::ERROR_COMMENT).filter(|comment| !comment.is_empty()),
        sop_class: text(tags::AFFECTED_SOP_CLASS_UID).unwrap_or_default(),
        sop_instance: text(tags::AFFECTED_SOP_INSTANCE_UID).unwrap_or_default(),
        has_data: number(tags::COMMAND_DATA_SET_TYPE).is_some_and(|kind| kind != 0x0101),
    })
}

/// The data set that follows a command, fragments passed to `sink` until the last (at most
/// `most` bytes in all).
fn receive_data(
    association: &mut Association,
    most: u64,
    mut sink: impl FnMut(&[u8]) -> Result<(), String>,
) -> Result<(), String> {
    let mut total = 0u64;
    loop {
        let started = std::time::Instant::now();
        let pdu = association.receive().map_err(|error| {
            timed_out(started, association.read_timeout(), "send the rest of a data set")
                .unwrap_or_else(|| chain(&error))
        })?;
        match pdu {
            Pdu::PData { data } => {
                for value in data {
                    if value.value_type != PDataValueType::Data {
                        return Err("a command arrived inside a data set".into());
                    }
                    total += value.data.len() as u64;
                    if total > most {
                        return Err(format!("a data set longer than {most} bytes"));
                    }
                    sink(&value.data)?;
                    if value.is_last {
                        return Ok(());
                    }
                }
            }
            Pdu::AbortRQ { source } => return Err(format!("the PACS aborted the association ({source:?})")),
            other => return Err(format!("an unexpected PDU inside a data set ({other:?})")),
        }
    }
}

/// Releases the association; a PACS that does not answer the release is only logged (every
/// answer that mattered has arrived).
fn release(association: Association, peer: &Peer) {
    if let Err(error) = association.release() {
        log::warn!("the PACS {} did not release the association cleanly: {}", peer.describe(), chain(&error));
    }
}

/// DIMSE status classes (PS3.7 Annex C).
fn is_pending(status: u16) -> bool {
    status == 0xFF00 || status == 0xFF01
}

fn is_warning(status: u16) -> bool {
    status == 0x0001 || (status & 0xF000) == 0xB000 || status == 0x0107 || status == 0x0116
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peers_parse_and_bad_ones_are_refused() {
        let peer = Peer::parse("ORTHANC@127.0.0.1:4242", "VOLASSO", Duration::from_secs(5)).unwrap();
        assert_eq!((peer.ae_title.as_str(), peer.host.as_str(), peer.port), ("ORTHANC", "127.0.0.1", 4242));
        let peer = Peer::parse("PACS@[::1]:104", "VOLASSO", Duration::from_secs(5)).unwrap();
        assert_eq!(peer.host, "::1");
        for bad in ["ORTHANC", "ORTHANC@host", "ORTHANC@host:0", "ORTHANC@host:x", "@host:1", "A\\B@h:1", "X@:104"] {
            assert!(Peer::parse(bad, "VOLASSO", Duration::from_secs(5)).is_err(), "{bad}");
        }
    }

    #[test]
    fn commands_round_trip_through_the_parser() {
        let bytes = command(0x0020, 7, "1.2.840.10008.5.1.4.1.2.2.1", Vec::new(), true);
        let received = parse_received(&bytes, 3).unwrap();
        assert_eq!((received.field, received.message_id, received.context), (0x0020, 7, 3));
        assert!(received.has_data);
        assert_eq!(received.sop_class, "1.2.840.10008.5.1.4.1.2.2.1");
    }
}
