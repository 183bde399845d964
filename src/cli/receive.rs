//! `volasso receive`: runs the DICOM storage SCP ([`crate::receive`]) until the process is
//! stopped; one JSON line per published or held-back series on stdout, a `listening on
//! ADDRESS` line on stderr once the port is open.

use super::CliError;
use crate::appliance::audit::{AuditLog, Event};
use crate::appliance::settings::{self, Effective};
use crate::receive::{Limits, ReceiveOptions, Timeouts, TlsFiles, serve};
use clap::Args;
use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

#[derive(Debug, Args)]
pub struct ReceiveArgs {
    /// The folder series are stored in (each complete series becomes one DICOM folder there).
    #[arg(long, value_name = "DIR")]
    pub data_dir: PathBuf,
    /// TCP port to listen on (0: any free port, printed on stderr) [default: the settings'
    /// `receive.port` in --data-dir, else 11112].
    #[arg(long)]
    pub port: Option<u16>,
    /// Address to listen on.
    #[arg(long, default_value = "0.0.0.0", value_name = "ADDRESS")]
    pub listen: std::net::IpAddr,
    /// This receiver's AE title; associations calling another title are refused [default: the
    /// settings' `receive.ae_title`, else VOLASSO].
    #[arg(long, env = "VOLASSO_AE_TITLE", value_name = "TITLE")]
    pub ae_title: Option<String>,
    /// Calling AE titles allowed to store, comma-separated [default: the settings'
    /// `receive.allowed_aes`, else any].
    #[arg(long, env = "VOLASSO_ALLOW_AE", value_delimiter = ',', value_name = "A,B")]
    pub allow_ae: Vec<String>,
    /// Refuse images (status A700, out of resources) when the data partition is fuller than this.
    #[arg(long, default_value_t = 90.0, value_name = "PERCENT", value_parser = parse_percent)]
    pub max_disk_use_percent: f64,
    /// Publish a series once no image of it has arrived for this long (sooner when all the
    /// images its data announce are there).
    #[arg(long, env = "VOLASSO_STABLE_AFTER", default_value = "60", value_name = "SECONDS", value_parser = parse_seconds)]
    pub stable_after: Duration,
    /// Associations served at once; more are rejected (A-ASSOCIATE-RJ, local limit exceeded).
    #[arg(long, default_value_t = 16, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub max_associations: u16,
    /// Associations served at once from one peer address; more are rejected likewise.
    #[arg(long, default_value_t = 8, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub max_associations_per_peer: u16,
    /// From a connection to its negotiated association (TLS handshake included).
    #[arg(long, default_value = "30", value_name = "SECONDS", value_parser = parse_positive_seconds)]
    pub acse_timeout: Duration,
    /// An association whose peer sends no PDU for this long is aborted.
    #[arg(long, default_value = "60", value_name = "SECONDS", value_parser = parse_positive_seconds)]
    pub idle_timeout: Duration,
    /// No association lasts longer than this, whatever its peer sends.
    #[arg(long, default_value = "3600", value_name = "SECONDS", value_parser = parse_positive_seconds)]
    pub association_timeout: Duration,
    /// Speak DICOM over TLS only (BCP 195 profile), with this certificate chain (PEM).
    #[arg(long, env = "VOLASSO_TLS_CERT", value_name = "PEM", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// The private key of --tls-cert (PEM).
    #[arg(long, env = "VOLASSO_TLS_KEY", value_name = "PEM", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// Require client certificates that chain to these CA certificates (PEM).
    #[arg(long, env = "VOLASSO_TLS_CA", value_name = "PEM", requires = "tls_cert")]
    pub tls_ca: Option<PathBuf>,
}

/// Seconds, decimals allowed, 0 or more (at most a year).
fn parse_seconds(text: &str) -> Result<Duration, String> {
    text.parse::<f64>()
        .ok()
        .filter(|seconds| (0.0..=365.0 * 86400.0).contains(seconds))
        .map(Duration::from_secs_f64)
        .ok_or_else(|| format!("'{text}' is not a number of seconds from 0 to a year"))
}

/// Seconds, decimals allowed, more than 0 (at most a year).
fn parse_positive_seconds(text: &str) -> Result<Duration, String> {
    parse_seconds(text)
        .ok()
        .filter(|duration| !duration.is_zero())
        .ok_or_else(|| format!("'{text}' is not a number of seconds above 0 and up to a year"))
}

fn parse_percent(text: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|percent| (0.0..=100.0).contains(percent))
        .ok_or_else(|| format!("'{text}' is not a percentage from 0 to 100"))
}

/// How often a receiver that the settings switch off looks at them again.
const SETTINGS_RECHECK: Duration = Duration::from_secs(5);

pub fn run(args: &ReceiveArgs) -> Result<(), CliError> {
    let settings = wait_until_enabled(&args.data_dir);
    let port = args.port.unwrap_or(settings.receive.port);
    let ae_title = args.ae_title.clone().unwrap_or(settings.receive.ae_title);
    let allow_ae = if args.allow_ae.is_empty() { settings.receive.allowed_aes } else { args.allow_ae.clone() };
    let address = std::net::SocketAddr::new(args.listen, port);
    let listener = TcpListener::bind(address).map_err(|source| CliError::Output {
        source,
        path: PathBuf::from(format!("{address} (the receiver's port)")),
    })?;
    let bound = listener.local_addr().map(|a| a.to_string()).unwrap_or_else(|_| address.to_string());
    if allow_ae.is_empty() {
        log::warn!("no --allow-ae given: any calling AE title may store");
    }
    let tls = match (&args.tls_cert, &args.tls_key) {
        (Some(cert), Some(key)) => Some(TlsFiles { cert: cert.clone(), key: key.clone(), ca: args.tls_ca.clone() }),
        _ => None,
    };
    let over = if tls.is_some() { " over TLS" } else { "" };
    eprintln!("volasso receive: listening on {bound} as {ae_title}{over}");
    let options = ReceiveOptions {
        ae_title,
        allowed_calling_ae: allow_ae.iter().map(|title| title.trim().to_string()).collect(),
        data_dir: args.data_dir.clone(),
        max_disk_use_fraction: args.max_disk_use_percent / 100.0,
        stable_after: args.stable_after,
        limits: Limits { total: args.max_associations.into(), per_peer: args.max_associations_per_peer.into() },
        timeouts: Timeouts { acse: args.acse_timeout, idle: args.idle_timeout, association: args.association_timeout },
        tls,
    };
    let log = AuditLog::of_writer(&args.data_dir, "receive");
    let output = AuditedLines { out: std::io::stdout(), line: Vec::new(), log };
    serve(listener, options, Arc::new(Mutex::new(output))).map_err(|error| CliError::Usage(error.to_string()))
}

/// The settings of `data_dir` once they let series in (`receive.enabled`; off in demo mode by
/// default): until then the receiver listens on nothing and looks again every
/// [`SETTINGS_RECHECK`], so an appliance switched to clinical mode starts receiving without a
/// restart. A settings file that cannot be used gives the safe defaults (said once).
fn wait_until_enabled(data_dir: &std::path::Path) -> Effective {
    let mut said = false;
    loop {
        let loaded = settings::load(data_dir);
        if let Some(problem) = &loaded.problem
            && !said
        {
            eprintln!("volasso receive: {problem}; running on the safe defaults");
        }
        let effective = loaded.settings.effective();
        if effective.receive.enabled {
            return effective;
        }
        if !said {
            eprintln!(
                "volasso receive: DICOM intake is off in the settings ({} mode, receive.enabled): not listening",
                if effective.mode == settings::Mode::Demo { "demo" } else { "clinical" }
            );
        }
        said = true;
        std::thread::sleep(SETTINGS_RECHECK);
    }
}

/// The receiver's JSON lines on their way to stdout: each series stored is also a
/// `series-received` line in the data folder's audit log (its UID hashed, its folder's name,
/// its images and the sender's AE title; never patient data).
struct AuditedLines {
    out: std::io::Stdout,
    /// The line being written, until its newline.
    line: Vec<u8>,
    log: AuditLog,
}

impl std::io::Write for AuditedLines {
    /// The audit line is written before the JSON line reaches stdout, so whoever reads the
    /// JSON line finds the audit line there.
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        for &byte in bytes {
            if byte != b'\n' {
                self.line.push(byte);
                continue;
            }
            let line = std::mem::take(&mut self.line);
            if let Ok(SeriesLine { event, series_uid, name, images, calling_ae }) = serde_json::from_slice(&line)
                && event == "stored"
            {
                let detail = format!("{name}, {images} images, from {calling_ae}");
                self.log.record_now(Event::SeriesReceived, Some(&series_uid), Some(&detail));
            }
        }
        self.out.write_all(bytes)?;
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// What the audit log takes of a receiver's JSON line.
#[derive(serde::Deserialize)]
struct SeriesLine {
    event: String,
    #[serde(default)]
    series_uid: String,
    #[serde(default)]
    name: String,
    #[serde(default)]
    images: usize,
    #[serde(default)]
    calling_ae: String,
}
