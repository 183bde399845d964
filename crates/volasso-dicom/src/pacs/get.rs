//! C-GET SCU (PS3.4 Annex C, Study Root Query/Retrieve Information Model - GET) of a study or
//! one series (by C-MOVE to the kiosk's own receiver where the PACS accepts no C-GET context or
//! refuses the C-GET before sending an image: `moving.rs`), with the storage sub-operations answered on the same association in the SCP
//! role (CT and MR images, every transfer syntax the reader decodes: the receiver's
//! [`crate::receive::STORAGE_SOP_CLASSES`] and [`crate::receive::accepted_transfer_syntaxes`]).
//!
//! Each image is written and flushed, read back by the kiosk's reader, and filed durably with
//! the receiver's own [`Store`]; when the C-GET has succeeded, each series is published by
//! [`Store::publish`] exactly as `volasso receive` publishes one (checked as the kiosk reads
//! it, swapped in atomically). A C-GET that fails or whose sub-operations failed publishes
//! nothing: its images stay in the receiver's pending folder (a running or later receiver
//! publishes them once stable).
//!
//! Images are refused (A700H) while the data partition is more than 90 % full, as the receiver
//! refuses them by default.
//!
//! Never: publishes a series that does not import cleanly, or acknowledges an image before it
//! is durable.

use super::{
    PacsError, Peer, command, encode, is_pending, native_syntaxes, priority, receive_command, receive_data, release,
    retrieve_identifier, send_message,
};
use crate::receive::dimse::{self, Command, status};
use crate::receive::store::{ImageCounts, Published, Store, remove_path, used_fraction};
use crate::receive::{STORAGE_SOP_CLASSES, SeriesReport, accepted_transfer_syntaxes};
use dicom_dictionary_std::uids;
use dicom_object::FileMetaTableBuilder;
use dicom_ul::Pdu;
use dicom_ul::pdu::{PDataValue, PDataValueType};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use volasso_core::volume::dicom;
use volasso_core::volume::limits::ReadLimits;

const GET: &str = uids::STUDY_ROOT_QUERY_RETRIEVE_INFORMATION_MODEL_GET;
/// The most bytes of one retrieved image.
const MOST_IMAGE_BYTES: u64 = 4 << 30;
/// Above this fraction of the data partition in use, retrieved images are refused (A700H), as
/// `volasso receive` refuses them by default.
const MOST_DISK_USE: f64 = 0.9;

/// Retrieves `study_uid` (or its series `series_uid`) from `peer` into `data_dir`; one report
/// per series published or held back.
pub fn get(
    peer: &Peer,
    data_dir: &Path,
    study_uid: &str,
    series_uid: Option<&str>,
) -> Result<Vec<SeriesReport>, PacsError> {
    get_counting(peer, data_dir, study_uid, series_uid, &|_| {})
}

/// [`get`], calling `stored` with the count of images filed so far after each one (the kiosk's
/// progress while a series arrives).
pub fn get_counting(
    peer: &Peer,
    data_dir: &Path,
    study_uid: &str,
    series_uid: Option<&str>,
    stored: &dyn Fn(u64),
) -> Result<Vec<SeriesReport>, PacsError> {
    let data_error = |source| PacsError::DataDir { source, path: data_dir.to_path_buf() };
    std::fs::create_dir_all(data_dir).map_err(data_error)?;
    let store = Store::join(data_dir).map_err(data_error)?;
    let folder = store.association_folder().map_err(data_error)?;
    let syntaxes: Vec<String> = accepted_transfer_syntaxes().into_iter().map(str::to_string).collect();
    let mut contexts = vec![(GET.to_string(), native_syntaxes())];
    contexts.extend(STORAGE_SOP_CLASSES.iter().map(|class| (class.to_string(), syntaxes.clone())));
    let mut association = match peer.associate(&contexts, &STORAGE_SOP_CLASSES) {
        Ok(association) => association,
        Err(error) => {
            remove_path(&folder);
            return Err(error);
        }
    };
    // A PACS that offers no C-GET sends by C-MOVE to the kiosk's receiver instead.
    if association.context_for(GET).is_none() {
        log::info!("{} offers no C-GET: retrieving by C-MOVE to {}", peer.describe(), peer.calling_ae_title);
        release(association, peer);
        remove_path(&folder);
        return super::moving::move_to_receiver(peer, data_dir, study_uid, series_uid, stored);
    }
    let mut retrieval =
        Retrieval { store: &store, folder: folder.clone(), next_file: 0, series: BTreeMap::new(), stored, filed: 0 };
    let result = retrieval.run(&mut association, peer, study_uid, series_uid);
    remove_path(&folder);
    match result {
        Ok(()) => release(association, peer),
        Err(error) => {
            let _ = association.abort();
            // A PACS that refuses this kiosk the C-GET it offered (Orthanc aborts the
            // association; others answer a failure) may still send by C-MOVE.
            if retrieval.filed == 0 && refused(&error) {
                log::info!("{} refused the C-GET ({error}): retrieving by C-MOVE", peer.describe());
                return super::moving::move_to_receiver(peer, data_dir, study_uid, series_uid, stored);
            }
            return Err(error);
        }
    }
    let mut reports = Vec::new();
    for (name, series_uid) in retrieval.series {
        reports.push(match store.publish(&name, &series_uid) {
            Ok(Published::Stored { check, images, received, replaced, .. }) => {
                let path = data_dir.join(&name);
                let counts = ImageCounts { images, received };
                SeriesReport::stored(name, path, series_uid, check, counts, replaced, peer.ae_title.clone())
            }
            Ok(Published::Held { images, received, reason }) => SeriesReport::Incomplete {
                name,
                series_uid,
                images,
                received,
                calling_ae: peer.ae_title.clone(),
                reason,
            },
            Ok(Published::Nothing) => continue,
            Err(error) => SeriesReport::Incomplete {
                name,
                series_uid,
                images: 0,
                received: 0,
                calling_ae: peer.ae_title.clone(),
                reason: format!("cannot write the series ({error})"),
            },
        });
    }
    Ok(reports)
}

/// One C-GET's state: where images arrive and the series they were filed under.
/// Whether `error` is the PACS refusing this kiosk C-GET itself, not the request: the
/// association aborted by the PACS (Orthanc's answer to a modality without C-GET), or "refused:
/// not authorized" (0124H), "SOP class not supported" (0122H), "unrecognized operation"
/// (0211H). An unknown study (C000H, say) is answered as it is.
fn refused(error: &PacsError) -> bool {
    match error {
        PacsError::Status { operation: "C-GET", status, .. } => matches!(status, 0x0122 | 0x0124 | 0x0211),
        PacsError::Protocol { problem, .. } => problem.starts_with("the PACS aborted the association"),
        _ => false,
    }
}

struct Retrieval<'a> {
    store: &'a Store,
    folder: PathBuf,
    next_file: u64,
    /// Series folder name to SeriesInstanceUID.
    series: BTreeMap<String, String>,
    /// Told the count of images filed after each one.
    stored: &'a dyn Fn(u64),
    filed: u64,
}

impl Retrieval<'_> {
    fn run(
        &mut self,
        association: &mut super::Association,
        peer: &Peer,
        study_uid: &str,
        series_uid: Option<&str>,
    ) -> Result<(), PacsError> {
        let protocol = |problem: String| PacsError::Protocol { peer: peer.describe(), problem };
        let (context, syntax) =
            association.context_for(GET).ok_or_else(|| protocol("the PACS accepted no C-GET context".into()))?;
        let data = encode(&retrieve_identifier(study_uid, series_uid), &syntax).map_err(protocol)?;
        send_message(association, context, command(0x0010, 1, GET, vec![priority()], true), Some(&data))
            .map_err(protocol)?;
        loop {
            let message = receive_command(association).map_err(protocol)?;
            match message.field {
                0x0001 => {
                    let request = Command {
                        field: message.field,
                        message_id: message.message_id,
                        affected_sop_class: message.sop_class.clone(),
                        affected_sop_instance: message.sop_instance.clone(),
                        has_data_set: message.has_data,
                    };
                    let (status, comment) = self.store_one(association, &request, message.context).map_err(protocol)?;
                    if status == dimse::status::SUCCESS {
                        self.filed += 1;
                        (self.stored)(self.filed);
                    }
                    association
                        .send(&Pdu::PData {
                            data: vec![PDataValue {
                                presentation_context_id: message.context,
                                value_type: PDataValueType::Command,
                                is_last: true,
                                data: dimse::response(&request, status, comment.as_deref()),
                            }],
                        })
                        .map_err(|error| protocol(super::chain(&error)))?;
                }
                0x8010 if is_pending(message.status) => {
                    if message.has_data {
                        receive_data(association, 1 << 20, |_| Ok(())).map_err(protocol)?;
                    }
                }
                0x8010 => {
                    if message.has_data {
                        receive_data(association, 1 << 20, |_| Ok(())).map_err(protocol)?;
                    }
                    if message.status == 0x0000 {
                        return Ok(());
                    }
                    return Err(PacsError::Status {
                        peer: peer.describe(),
                        operation: "C-GET",
                        status: message.status,
                        comment: message.comment.or_else(|| {
                            (message.status == 0xB000).then(|| "some images could not be sent".to_string())
                        }),
                    });
                }
                other => return Err(protocol(format!("a command {other:#06x} during a C-GET"))),
            }
        }
    }

    /// Receives one C-STORE sub-operation's data set into a file and files it; the status to
    /// answer with.
    fn store_one(
        &mut self,
        association: &mut super::Association,
        request: &Command,
        context_id: u8,
    ) -> Result<(u16, Option<String>), String> {
        let context = association
            .presentation_contexts()
            .iter()
            .find(|context| context.id == context_id)
            .map(|context| (context.abstract_syntax.clone(), context.transfer_syntax.clone()));
        let Some((abstract_syntax, transfer_syntax)) = context else {
            return Err(format!("a C-STORE on presentation context {context_id}, which was not negotiated"));
        };
        if !request.has_data_set {
            return Ok((status::CANNOT_UNDERSTAND, Some("a C-STORE request without a data set".into())));
        }
        let full = match used_fraction(self.store.data_dir()) {
            Ok(fraction) if fraction <= MOST_DISK_USE => None,
            Ok(fraction) => Some(format!("the kiosk's disk is {:.0} % full", fraction * 100.0)),
            Err(_) => Some("cannot tell how full the kiosk's disk is".to_string()),
        };
        if let Some(problem) = full {
            log::warn!("refusing a retrieved image: {problem}");
            receive_data(association, MOST_IMAGE_BYTES, |_| Ok(()))?;
            return Ok((status::OUT_OF_RESOURCES, Some(problem)));
        }
        let path = self.folder.join(format!("{}.dcm", self.next_file));
        self.next_file += 1;
        let opened = (|| -> std::io::Result<std::io::BufWriter<std::fs::File>> {
            let meta = FileMetaTableBuilder::new()
                .media_storage_sop_class_uid(request.affected_sop_class.as_str())
                .media_storage_sop_instance_uid(request.affected_sop_instance.as_str())
                .transfer_syntax(transfer_syntax.as_str())
                .build()
                .map_err(std::io::Error::other)?;
            let mut writer = std::io::BufWriter::new(std::fs::File::create_new(&path)?);
            writer.write_all(&[0u8; 128])?;
            writer.write_all(b"DICM")?;
            meta.write(&mut writer).map_err(std::io::Error::other)?;
            Ok(writer)
        })();
        let mut failure: Option<String> = None;
        let mut writer = match opened {
            Ok(writer) => Some(writer),
            Err(error) => {
                failure = Some(format!("cannot create a file: {error}"));
                None
            }
        };
        receive_data(association, MOST_IMAGE_BYTES, |chunk| {
            if let Some(file) = writer.as_mut()
                && let Err(error) = file.write_all(chunk)
            {
                failure = Some(format!("cannot write the image: {error}"));
                writer = None;
            }
            Ok(())
        })?;
        let flushed = writer
            .ok_or(())
            .and_then(|writer| writer.into_inner().map_err(|_| ()).and_then(|file| file.sync_all().map_err(|_| ())));
        if flushed.is_err() {
            remove_path(&path);
            return Ok((status::PROCESSING_FAILURE, Some(failure.unwrap_or_else(|| "cannot write the image".into()))));
        }
        let refuse = |status: u16, problem: String| {
            log::warn!("refused a retrieved image ({status:#06x}): {problem}");
            remove_path(&path);
            Ok((status, Some(problem)))
        };
        if abstract_syntax != request.affected_sop_class {
            return refuse(status::SOP_CLASS_NOT_SUPPORTED, "SOP class differs from the context's".into());
        }
        let limits = ReadLimits::default();
        let identity = match dicom::read_identity(&path, &limits) {
            Ok(identity) => identity,
            Err(error) => {
                return refuse(
                    status::CANNOT_UNDERSTAND,
                    error.to_string().replace(&path.display().to_string(), "the image"),
                );
            }
        };
        if identity.series_uid.is_empty() || identity.sop_instance_uid != request.affected_sop_instance {
            return refuse(
                status::DATA_SET_DOES_NOT_MATCH,
                "no Series Instance UID, or another SOP Instance UID".into(),
            );
        }
        match self.store.accept(&path, &identity.modality, &identity.series_uid, &identity.sop_instance_uid) {
            Ok(accepted) => {
                self.series.insert(accepted.name, identity.series_uid);
                Ok((status::SUCCESS, None))
            }
            Err(error) => {
                remove_path(&path);
                Ok((status::PROCESSING_FAILURE, Some(format!("cannot store the image: {error}"))))
            }
        }
    }
}
