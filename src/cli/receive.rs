//! `volasso receive`: runs the DICOM storage SCP ([`crate::receive`]) until the process is
//! stopped; one JSON line per stored series on stdout, a `listening on ADDRESS` line on stderr
//! once the port is open.

use super::CliError;
use crate::receive::{ReceiveOptions, serve};
use clap::Args;
use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

#[derive(Debug, Args)]
pub struct ReceiveArgs {
    /// The folder series are stored in (each complete series becomes one DICOM folder there).
    #[arg(long, value_name = "DIR")]
    pub data_dir: PathBuf,
    /// TCP port to listen on (0: any free port, printed on stderr).
    #[arg(long, default_value_t = 11112)]
    pub port: u16,
    /// Address to listen on.
    #[arg(long, default_value = "0.0.0.0", value_name = "ADDRESS")]
    pub listen: std::net::IpAddr,
    /// This receiver's AE title; associations calling another title are refused.
    #[arg(long, env = "VOLASSO_AE_TITLE", default_value = "VOLASSO", value_name = "TITLE")]
    pub ae_title: String,
    /// Calling AE titles allowed to store, comma-separated (default: any).
    #[arg(long, env = "VOLASSO_ALLOW_AE", value_delimiter = ',', value_name = "A,B")]
    pub allow_ae: Vec<String>,
    /// Refuse images (status A700, out of resources) when the data partition is fuller than this.
    #[arg(long, default_value_t = 90.0, value_name = "PERCENT", value_parser = parse_percent)]
    pub max_disk_use_percent: f64,
}

fn parse_percent(text: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|percent| (0.0..=100.0).contains(percent))
        .ok_or_else(|| format!("'{text}' is not a percentage from 0 to 100"))
}

pub fn run(args: &ReceiveArgs) -> Result<(), CliError> {
    let address = std::net::SocketAddr::new(args.listen, args.port);
    let listener = TcpListener::bind(address).map_err(|source| CliError::Output {
        source,
        path: PathBuf::from(format!("{address} (the receiver's port)")),
    })?;
    let bound = listener.local_addr().map(|a| a.to_string()).unwrap_or_else(|_| address.to_string());
    if args.allow_ae.is_empty() {
        log::warn!("no --allow-ae given: any calling AE title may store");
    }
    eprintln!("volasso receive: listening on {bound} as {}", args.ae_title);
    let options = ReceiveOptions {
        ae_title: args.ae_title.clone(),
        allowed_calling_ae: args.allow_ae.iter().map(|title| title.trim().to_string()).collect(),
        data_dir: args.data_dir.clone(),
        max_disk_use_fraction: args.max_disk_use_percent / 100.0,
    };
    serve(listener, options, Arc::new(Mutex::new(std::io::stdout())))
        .map_err(|error| CliError::Usage(error.to_string()))
}
