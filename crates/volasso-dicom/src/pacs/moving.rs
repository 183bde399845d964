//! C-MOVE SCU (PS3.4 Annex C, Study Root Query/Retrieve Information Model - MOVE): where a PACS
//! offers no C-GET, the kiosk asks it to send the series to the kiosk's own receiver (`volasso
//! receive`, the appliance's `volasso-receive.service`), whose AE title is this client's calling
//! AE title and whose address the PACS has configured. The receiver files and publishes each
//! series as for any push (whole, checked, atomically); this waits until every CT and MR series
//! the PACS listed for the request is published in the data folder.
//!
//! Never: reports a series retrieved before the receiver has published it whole, or waits past
//! [`RECEIVER_PATIENCE`] after the PACS said it sent everything.

use super::find::{FIND, series_of};
use super::{
    PacsError, Peer, command, encode, is_pending, native_syntaxes, priority, receive_command, receive_data, release,
    retrieve_identifier, send_message,
};
use crate::receive::SeriesReport;
use crate::receive::store::{ImageCounts, check_series, series_name};
use dicom_core::{DataElement, PrimitiveValue, VR};
use dicom_dictionary_std::{tags, uids};
use std::path::Path;
use std::time::{Duration, Instant};
use volasso_core::volume::limits::ReadLimits;

const MOVE: &str = uids::STUDY_ROOT_QUERY_RETRIEVE_INFORMATION_MODEL_MOVE;

/// How long the receiver may take to publish the series after the PACS has sent them: its
/// default `--stable-after` (60 s) for series whose images do not say how many they are, and
/// the time to check them.
pub const RECEIVER_PATIENCE: Duration = Duration::from_secs(120);

/// Moves `study_uid` (or its series `series_uid`) from `peer` to the kiosk's receiver and waits
/// for it to publish the CT and MR series in `data_dir`; `stored` hears the count of images
/// published so far.
pub(super) fn move_to_receiver(
    peer: &Peer,
    data_dir: &Path,
    study_uid: &str,
    series_uid: Option<&str>,
    stored: &dyn Fn(u64),
) -> Result<Vec<SeriesReport>, PacsError> {
    let contexts = [(FIND.to_string(), native_syntaxes()), (MOVE.to_string(), native_syntaxes())];
    let mut association = peer.associate(&contexts, &[])?;
    let result = (|| {
        let series = series_of(&mut association, peer, study_uid, series_uid, 1)?;
        request_move(&mut association, peer, study_uid, series_uid)?;
        Ok(series)
    })();
    let series = match result {
        Ok(series) => {
            release(association, peer);
            series
        }
        Err(error) => {
            let _ = association.abort();
            return Err(error);
        }
    };
    let wanted: Vec<_> = series.into_iter().filter(|series| matches!(series.modality.as_str(), "CT" | "MR")).collect();
    wait_for_receiver(peer, data_dir, &wanted, stored)
}

/// Sends the C-MOVE request to this client's AE title and reads its responses to the end.
fn request_move(
    association: &mut super::Association,
    peer: &Peer,
    study_uid: &str,
    series_uid: Option<&str>,
) -> Result<(), PacsError> {
    let protocol = |problem: String| PacsError::Protocol { peer: peer.describe(), problem };
    let (context, syntax) = association
        .context_for(MOVE)
        .ok_or_else(|| protocol("the PACS accepted neither a C-GET nor a C-MOVE context".into()))?;
    let data = encode(&retrieve_identifier(study_uid, series_uid), &syntax).map_err(protocol)?;
    let extra = vec![
        priority(),
        DataElement::new(tags::MOVE_DESTINATION, VR::AE, PrimitiveValue::from(peer.calling_ae_title.as_str())),
    ];
    send_message(association, context, command(0x0021, 2, MOVE, extra, true), Some(&data)).map_err(protocol)?;
    loop {
        let response = receive_command(association).map_err(protocol)?;
        if response.field != 0x8021 {
            return Err(protocol(format!("a command {:#06x} where a C-MOVE response was expected", response.field)));
        }
        if response.has_data {
            receive_data(association, 1 << 20, |_| Ok(())).map_err(protocol)?;
        }
        if is_pending(response.status) {
            continue;
        }
        if response.status == 0x0000 {
            return Ok(());
        }
        let comment = response.comment.or_else(|| match response.status {
            0xA801 => Some(format!("the PACS does not know the destination {}", peer.calling_ae_title)),
            0xB000 => Some("some images could not be sent".to_string()),
            _ => None,
        });
        return Err(PacsError::Status { peer: peer.describe(), operation: "C-MOVE", status: response.status, comment });
    }
}

/// Waits until the receiver has published every series of `wanted` in `data_dir`.
fn wait_for_receiver(
    peer: &Peer,
    data_dir: &Path,
    wanted: &[super::SeriesFound],
    stored: &dyn Fn(u64),
) -> Result<Vec<SeriesReport>, PacsError> {
    let deadline = Instant::now() + RECEIVER_PATIENCE;
    let mut reports: Vec<Option<SeriesReport>> = vec![None; wanted.len()];
    let mut images = 0;
    loop {
        for (series, report) in wanted.iter().zip(reports.iter_mut()) {
            if report.is_some() {
                continue;
            }
            let name = series_name(&series.modality, &series.series_uid);
            let path = data_dir.join(&name);
            // The receiver swaps a series in whole: a folder there is all of it.
            let Ok(files) = std::fs::read_dir(&path) else { continue };
            let count = files.filter_map(Result::ok).filter(|entry| entry.path().is_file()).count();
            images += count as u64;
            stored(images);
            // Read back as the receiver checked it before publishing (the dims for the report).
            let uid = series.series_uid.clone();
            *report = Some(match check_series(&path, &uid, &ReadLimits::default()) {
                Ok(check) => {
                    let counts = ImageCounts { images: count, received: count };
                    SeriesReport::stored(name, path, uid, check, counts, false, peer.ae_title.clone())
                }
                Err(error) => SeriesReport::Incomplete {
                    name,
                    series_uid: uid,
                    images: count,
                    received: count,
                    calling_ae: peer.ae_title.clone(),
                    reason: error.to_string(),
                },
            });
        }
        if reports.iter().all(Option::is_some) {
            return Ok(reports.into_iter().flatten().collect());
        }
        if Instant::now() >= deadline {
            let missing = reports.iter().filter(|report| report.is_none()).count();
            return Err(PacsError::ReceiverSilent {
                peer: peer.describe(),
                destination: peer.calling_ae_title.clone(),
                missing,
                seconds: RECEIVER_PATIENCE.as_secs(),
                data_dir: data_dir.to_path_buf(),
            });
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}
