//! `volasso pacs find|get|send`: the kiosk as a DICOM client of a PACS ([`crate::pacs`]). Each
//! prints one JSON line per study found, series retrieved or file sent, and exits non-zero with
//! one sentence when the PACS is down, refuses the association or answers a failure.

use super::CliError;
use crate::pacs::{FindQuery, PacsError, Peer};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use std::time::Duration;

#[derive(Debug, Subcommand)]
pub enum PacsCommand {
    /// C-FIND: one JSON line per matching study, with its series.
    Find(FindArgs),
    /// C-GET: retrieve a study or series into the data folder, published as a received series.
    Get(GetArgs),
    /// C-STORE: store DICOM files (e.g. what `volasso export` wrote).
    Send(SendArgs),
}

#[derive(Debug, Args)]
pub struct PeerArgs {
    /// The PACS, as AE@host:port; repeatable, or several separated by commas: `find` asks
    /// each, `get` retrieves from the first that has the study, `send` stores on each.
    #[arg(long, env = "VOLASSO_PACS", value_delimiter = ',', required = true, value_name = "AE@HOST:PORT")]
    pub pacs: Vec<String>,
    /// This kiosk's AE title (the calling AE title).
    #[arg(long, env = "VOLASSO_AE_TITLE", default_value = "VOLASSO", value_name = "TITLE")]
    pub ae_title: String,
    /// Bounds the connection and each read and write, in seconds.
    #[arg(long, default_value_t = 30.0, value_name = "SECONDS", value_parser = parse_timeout)]
    pub timeout: f64,
    #[command(flatten)]
    pub tls: ClientTlsArgs,
}

/// DICOM over TLS to the PACS.
#[derive(Debug, Args, Clone, Default)]
pub struct ClientTlsArgs {
    /// Connect over TLS (BCP 195: TLS 1.2 or 1.3), trusting a PACS whose certificate chains to
    /// one of these CA certificates (PEM) and names its host or address.
    #[arg(long = "tls-ca", env = "VOLASSO_PACS_TLS_CA", value_name = "PEM")]
    pub ca: Option<PathBuf>,
    /// The kiosk's certificate chain (PEM), presented when the PACS asks for one.
    #[arg(long = "tls-cert", env = "VOLASSO_PACS_TLS_CERT", value_name = "PEM", requires_all = ["ca", "key"])]
    pub cert: Option<PathBuf>,
    /// The private key of `--tls-cert` (PEM).
    #[arg(long = "tls-key", env = "VOLASSO_PACS_TLS_KEY", value_name = "PEM", requires = "cert")]
    pub key: Option<PathBuf>,
}

impl ClientTlsArgs {
    /// The TLS configuration; `None` without `--tls-ca`.
    pub fn config(&self) -> Result<Option<crate::pacs::TlsConfig>, PacsError> {
        let Some(ca) = &self.ca else { return Ok(None) };
        let identity = self.cert.as_deref().zip(self.key.as_deref());
        Ok(Some(crate::receive::tls::client_config(ca, identity)?))
    }
}

impl PeerArgs {
    /// Every PACS given, in order; the first that does not parse is the error.
    fn peers(&self) -> Result<Vec<Peer>, PacsError> {
        let timeout = Duration::from_secs_f64(self.timeout);
        let tls = self.tls.config()?;
        let peer =
            |text: &String| Peer::parse(text, &self.ae_title, timeout).map(|peer| Peer { tls: tls.clone(), ..peer });
        self.pacs.iter().map(peer).collect()
    }
}

/// One JSON line: `value` with the PACS it came from.
fn line_from(value: &impl serde::Serialize, peer: &Peer) -> String {
    let mut value = serde_json::to_value(value).unwrap_or_default();
    if let Some(object) = value.as_object_mut() {
        object.insert("pacs".into(), peer.describe().into());
    }
    value.to_string()
}

fn parse_timeout(text: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|seconds| seconds.is_finite() && *seconds > 0.0 && *seconds <= 86_400.0)
        .ok_or_else(|| format!("'{text}' is not a number of seconds above 0 and at most 86400"))
}

#[derive(Debug, Args)]
pub struct FindArgs {
    #[command(flatten)]
    pub peer: PeerArgs,
    /// Only this PatientID.
    #[arg(long, value_name = "ID")]
    pub patient_id: Option<String>,
    /// Only this AccessionNumber.
    #[arg(long, value_name = "N")]
    pub accession: Option<String>,
    /// Only studies with this modality (CT, MR...).
    #[arg(long, value_name = "MODALITY")]
    pub modality: Option<String>,
    /// Only studies on or after this date.
    #[arg(long, value_name = "YYYYMMDD", value_parser = parse_date)]
    pub since: Option<String>,
}

fn parse_date(text: &str) -> Result<String, String> {
    let valid = text.len() == 8
        && text.bytes().all(|byte| byte.is_ascii_digit())
        && (1..=12).contains(&text[4..6].parse::<u32>().unwrap_or(0))
        && (1..=31).contains(&text[6..8].parse::<u32>().unwrap_or(0));
    if valid { Ok(text.to_string()) } else { Err(format!("'{text}' is not a date YYYYMMDD")) }
}

#[derive(Debug, Args)]
pub struct GetArgs {
    #[command(flatten)]
    pub peer: PeerArgs,
    /// The folder series are published in (as `volasso receive --data-dir`).
    #[arg(long, env = "VOLASSO_DATA_DIR", value_name = "DIR")]
    pub data_dir: PathBuf,
    /// The study to retrieve.
    pub study_uid: String,
    /// Only this series of it.
    pub series_uid: Option<String>,
}

#[derive(Debug, Args)]
pub struct SendArgs {
    #[command(flatten)]
    pub peer: PeerArgs,
    /// The DICOM files to store.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
}

pub fn run(command: &PacsCommand) -> Result<(), CliError> {
    match command {
        PacsCommand::Find(args) => {
            let query = FindQuery {
                patient_id: args.patient_id.clone(),
                accession_number: args.accession.clone(),
                modality: args.modality.clone(),
                since: args.since.clone(),
            };
            // Every PACS is asked; one that fails is the error, after the others' studies.
            let mut failure = None;
            for peer in args.peer.peers()? {
                match crate::pacs::find(&peer, &query) {
                    Ok(studies) => studies.iter().for_each(|study| println!("{}", line_from(study, &peer))),
                    Err(error) => failure = Some(error),
                }
            }
            failure.map_or(Ok(()), |error| Err(error.into()))
        }
        PacsCommand::Get(args) => {
            let mut last = None;
            for peer in args.peer.peers()? {
                match get_from(&peer, args) {
                    Ok(()) => return Ok(()),
                    // Another PACS may hold the study; one that published part of it has spoken.
                    Err(error @ CliError::Pacs(PacsError::NotAllPublished { .. })) => return Err(error),
                    Err(error) => last = Some(error),
                }
            }
            last.map_or(Ok(()), Err)
        }
        PacsCommand::Send(args) => {
            let mut failure = None;
            for peer in args.peer.peers()? {
                let reports = match crate::pacs::send(&peer, &args.files) {
                    Ok(reports) => reports,
                    Err(error) => {
                        failure = Some(error);
                        continue;
                    }
                };
                reports.iter().for_each(|report| println!("{}", line_from(report, &peer)));
                let failed = reports.iter().filter(|report| !report.stored).count();
                if failed > 0 {
                    failure = Some(PacsError::NotAllStored { failed, total: reports.len(), peer: peer.describe() });
                }
            }
            failure.map_or(Ok(()), |error| Err(error.into()))
        }
    }
}

/// `get` from one PACS: its lines printed, an error when it published nothing or not all.
fn get_from(peer: &Peer, args: &GetArgs) -> Result<(), CliError> {
    let reports = crate::pacs::get(peer, &args.data_dir, &args.study_uid, args.series_uid.as_deref())?;
    let mut failed = 0;
    for report in &reports {
        failed += usize::from(matches!(report, crate::receive::SeriesReport::Incomplete { .. }));
        println!("{}", line_from(report, peer));
    }
    if failed > 0 {
        return Err(PacsError::NotAllPublished { failed }.into());
    }
    if reports.is_empty() {
        let uid = args.series_uid.clone().unwrap_or_else(|| args.study_uid.clone());
        return Err(PacsError::NothingRetrieved { uid, peer: peer.describe() }.into());
    }
    Ok(())
}
