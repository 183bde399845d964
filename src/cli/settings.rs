//! `volasso settings --data-dir DIR show | set KEY VALUE` and `volasso audit --data-dir DIR
//! [--since WHEN]`: the appliance's settings file and audit log from the command line, for an
//! installer and for hospital IT (the formats: `docs/interfaces.md`).

use super::CliError;
use crate::appliance::audit::{AuditLog, Event};
use crate::appliance::settings;
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct SettingsArgs {
    /// The appliance's data folder, which holds `settings.toml`.
    #[arg(long, env = "VOLASSO_DATA_DIR")]
    pub data_dir: PathBuf,
    #[command(subcommand)]
    pub command: SettingsCommand,
}

#[derive(Debug, Subcommand)]
pub enum SettingsCommand {
    /// Print the settings in effect (each mode's defaults applied) as one JSON object; with a
    /// settings file that cannot be used, the safe defaults and a non-zero exit status.
    Show,
    /// Print one setting in effect, as `set` takes it (a list comma-separated): what a service's
    /// start script needs (the appliance's firewall opens `receive.port`); with a settings file
    /// that cannot be used, the safe default and a non-zero exit status.
    Get {
        /// A key `set` takes (`receive.port`).
        key: String,
    },
    /// Change one setting (`default` gives it back to its mode) and write the file atomically.
    Set {
        /// mode, language, idle_timeout_s, retention_hours, usb_export, receive.enabled,
        /// receive.ae_title, receive.port, receive.allowed_aes, pacs, panel.rotation_degrees or
        /// panel.dpi.
        key: String,
        #[arg(allow_hyphen_values = true)]
        value: String,
    },
    /// Choose the PIN of the kiosk's settings screen (4 to 8 digits, read from standard input
    /// so that it is neither in the shell's history nor in the process list); kept as a salted
    /// hash in `DIR/pin`.
    SetPin,
}

#[derive(Debug, Args)]
pub struct AuditArgs {
    /// The appliance's data folder, which holds `audit/`.
    #[arg(long, env = "VOLASSO_DATA_DIR")]
    pub data_dir: PathBuf,
    /// Only events at or after this time: seconds since 1970, or a UTC date `YYYY-MM-DD`.
    #[arg(long, value_parser = parse_since, value_name = "WHEN")]
    pub since: Option<u64>,
}

pub fn run(args: &SettingsArgs) -> Result<(), CliError> {
    match &args.command {
        SettingsCommand::Show => {
            let loaded = settings::load(&args.data_dir);
            println!("{}", serde_json::to_string(&loaded.settings.effective()).unwrap_or_default());
            match loaded.problem {
                Some(problem) => Err(problem.into()),
                None => Ok(()),
            }
        }
        SettingsCommand::Get { key } => {
            let loaded = settings::load(&args.data_dir);
            let value = loaded.settings.effective().value(key);
            let value = value.ok_or_else(|| settings::SettingsError::UnknownKey { key: key.clone() })?;
            println!("{value}");
            match loaded.problem {
                Some(problem) => Err(problem.into()),
                None => Ok(()),
            }
        }
        SettingsCommand::Set { key, value } => {
            // A damaged file is refused, not overwritten: it is kept for whoever looks into it.
            let mut current = settings::read(&args.data_dir)?.unwrap_or_default();
            current.set(key, value)?;
            settings::write(&args.data_dir, &current)?;
            let detail = format!("{key}={}", value.trim());
            AuditLog::new(&args.data_dir).record_now(Event::SettingsChanged, None, Some(&detail));
            Ok(())
        }
        SettingsCommand::SetPin => {
            let mut line = String::new();
            std::io::stdin()
                .read_line(&mut line)
                .map_err(|source| CliError::Output { source, path: "standard input".into() })?;
            crate::appliance::pin::set(&args.data_dir, line.trim_end_matches(['\n', '\r']))
                .map_err(|error| CliError::Usage(error.to_string()))?;
            AuditLog::new(&args.data_dir).record_now(Event::SettingsChanged, None, Some("pin"));
            Ok(())
        }
    }
}

pub fn run_audit(args: &AuditArgs) -> Result<(), CliError> {
    let entries = AuditLog::new(&args.data_dir)
        .entries(args.since.unwrap_or(0))
        .map_err(|source| CliError::Output { source, path: args.data_dir.join(crate::appliance::audit::FOLDER) })?;
    for entry in entries {
        println!("{}", serde_json::to_string(&entry).unwrap_or_default());
    }
    Ok(())
}

/// Seconds since 1970, or `YYYY-MM-DD` (UTC midnight).
fn parse_since(text: &str) -> Result<u64, String> {
    if let Ok(seconds) = text.parse::<u64>() {
        return Ok(seconds);
    }
    let parts: Vec<&str> = text.split('-').collect();
    let [year, month, day] = parts[..] else { return Err(format!("{text:?} is not seconds since 1970 or YYYY-MM-DD")) };
    let number = |part: &str, low: i64, high: i64| part.parse::<i64>().ok().filter(|n| (low..=high).contains(n));
    let (Some(year), Some(month), Some(day)) = (number(year, 1970, 9999), number(month, 1, 12), number(day, 1, 31))
    else {
        return Err(format!("{text:?} is not seconds since 1970 or a date YYYY-MM-DD"));
    };
    let days = crate::calendar::days_from_civil(year, month, day);
    if crate::calendar::civil_from_days(days) != [year, month, day] {
        return Err(format!("{text:?} is not a day of the calendar"));
    }
    Ok(days as u64 * 86_400)
}
