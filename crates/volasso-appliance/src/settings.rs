//! The appliance's settings: one TOML file, `settings.toml` in the data folder, written
//! atomically and read by the kiosk and the receiver. Command-line flags still override it for
//! development.
//!
//! Two modes want opposite things ([`Mode`]): `clinical` (a bedside: the patient identified on
//! screen, data kept [`CLINICAL_RETENTION_HOURS`] and no USB export unless allowed) and `demo`
//! (a conference stand: no patient data anywhere, data kept, USB export on, DICOM intake off
//! unless enabled). A setting left out takes its mode's default ([`Settings::effective`]).
//!
//! A file that cannot be read or holds a bad value (garbage, a negative timeout, an unknown key)
//! is never half applied: [`load`] gives the safe defaults with one message naming the file and
//! the problem, so the appliance starts and says why instead of stopping in a restart loop. The
//! safe default mode is `clinical`: on a ward, a screen that hides whose scan it is risks the
//! wrong patient, and clinical mode also keeps data shortest and nothing on a USB stick.
//!
//! Never: applies a setting itself (the kiosk and the receiver read [`Effective`]), or writes a
//! file it could not read (a `set` on a damaged file is refused, the file kept for inspection).

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;
use volasso_core::atomic_file::write_atomically;
use volasso_core::volume::dicom::PatientShown;

/// The file's name in the data folder.
pub const FILE: &str = "settings.toml";

/// How long received data stays in clinical mode unless set otherwise.
pub const CLINICAL_RETENTION_HOURS: u64 = 24;

/// The longest idle timeout, retention and file read.
const MAX_IDLE_TIMEOUT_S: u64 = 24 * 3600;
const MAX_RETENTION_HOURS: u64 = 24 * 365;
const MAX_FILE_BYTES: u64 = 64 << 10;

/// How long the kiosk waits for a PACS when its address is checked.
const PACS_TIMEOUT: Duration = Duration::from_secs(30);

/// Why settings cannot be read, written or changed; the path last where there is one.
#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    #[error("cannot read the settings: {source}, in {}", path.display())]
    Read { source: std::io::Error, path: PathBuf },
    #[error("the settings file is {bytes} bytes, more than settings can be, in {}", path.display())]
    TooLarge { bytes: u64, path: PathBuf },
    #[error("the settings file does not parse: {message}, in {}", path.display())]
    Parse { message: String, path: PathBuf },
    #[error("{key}: {problem}")]
    Value { key: String, problem: String },
    #[error("no setting is called {key:?}; the settings are {}", KEYS.join(", "))]
    UnknownKey { key: String },
    #[error("cannot write the settings: {source}, in {}", path.display())]
    Write { source: std::io::Error, path: PathBuf },
}

/// Where the appliance is used.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// A bedside: whose scan it is, on screen; data expires; nothing leaves on a stick unless
    /// allowed.
    #[default]
    Clinical,
    /// A conference stand: nobody identifiable anywhere; snapshots go home on a stick.
    Demo,
}

/// The language of the screens.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Language {
    #[default]
    En,
    De,
}

/// The DICOM receiver's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Receive {
    /// Whether series are received; `None`: on in clinical mode, off in demo mode.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub enabled: Option<bool>,
    pub ae_title: String,
    pub port: u16,
    /// The calling AE titles accepted; empty: any.
    pub allowed_aes: Vec<String>,
}

impl Default for Receive {
    fn default() -> Self {
        Receive { enabled: None, ae_title: "VOLASSO".into(), port: 11112, allowed_aes: Vec::new() }
    }
}

/// The panel's settings.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Panel {
    /// How the panel is mounted: 0, 90, 180 or 270 degrees.
    pub rotation_degrees: u16,
    /// The panel's pixel density; `None`: from the display, else the kiosk's default.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dpi: Option<f32>,
}

/// The settings as the file holds them: what is left out is `None` or its default.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Settings {
    pub mode: Mode,
    pub language: Language,
    /// Seconds without a touch before the start screen returns; `None`: the kiosk's default
    /// (two minutes); 0: never.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub idle_timeout_s: Option<u64>,
    /// Hours received data, sessions, gallery entries and snapshots are kept; `None`: the
    /// mode's default; 0: kept until deleted by hand.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub retention_hours: Option<u64>,
    /// Whether snapshots are copied to USB sticks; `None`: the mode's default.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub usb_export: Option<bool>,
    pub receive: Receive,
    /// The PACS peers, as `AE@host:port`.
    pub pacs: Vec<String>,
    pub panel: Panel,
}

/// Every setting with a value, its mode's defaults applied: what the appliance does.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Effective {
    pub mode: Mode,
    pub language: Language,
    pub idle_timeout_s: u64,
    /// 0: data is kept.
    pub retention_hours: u64,
    pub usb_export: bool,
    pub receive: EffectiveReceive,
    pub pacs: Vec<String>,
    pub panel: Panel,
}

/// The receiver's settings in effect.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EffectiveReceive {
    pub enabled: bool,
    pub ae_title: String,
    pub port: u16,
    pub allowed_aes: Vec<String>,
}

impl Effective {
    /// The setting `key` in effect as [`Settings::set`] takes it: a list comma-separated, a
    /// density left to the display `default`; `None` for a key `set` does not take.
    pub fn value(&self, key: &str) -> Option<String> {
        Some(match key {
            "mode" => (if self.mode == Mode::Demo { "demo" } else { "clinical" }).into(),
            "language" => (if self.language == Language::De { "de" } else { "en" }).into(),
            "idle_timeout_s" => self.idle_timeout_s.to_string(),
            "retention_hours" => self.retention_hours.to_string(),
            "usb_export" => self.usb_export.to_string(),
            "receive.enabled" => self.receive.enabled.to_string(),
            "receive.ae_title" => self.receive.ae_title.clone(),
            "receive.port" => self.receive.port.to_string(),
            "receive.allowed_aes" => self.receive.allowed_aes.join(","),
            "pacs" => self.pacs.join(","),
            "panel.rotation_degrees" => self.panel.rotation_degrees.to_string(),
            "panel.dpi" => self.panel.dpi.map_or("default".into(), |dpi| dpi.to_string()),
            _ => return None,
        })
    }

    /// How long the kiosk waits without a touch; `None`: never.
    pub fn idle_timeout(&self) -> Option<Duration> {
        (self.idle_timeout_s > 0).then(|| Duration::from_secs(self.idle_timeout_s))
    }

    /// How long patient data is kept; `None`: until deleted by hand.
    pub fn retention(&self) -> Option<Duration> {
        (self.retention_hours > 0).then(|| Duration::from_secs(self.retention_hours * 3600))
    }

    /// Whether the screens show whose scan it is: at a bedside, never at a conference stand.
    pub fn patient_shown(&self) -> PatientShown {
        match self.mode {
            Mode::Clinical => PatientShown::Shown,
            Mode::Demo => PatientShown::Hidden,
        }
    }
}

/// The kiosk's idle timeout when none is set.
pub const DEFAULT_IDLE_TIMEOUT_S: u64 = 120;

impl Settings {
    /// What the appliance does with these settings: each one left out takes its mode's
    /// default.
    pub fn effective(&self) -> Effective {
        let clinical = self.mode == Mode::Clinical;
        Effective {
            mode: self.mode,
            language: self.language,
            idle_timeout_s: self.idle_timeout_s.unwrap_or(DEFAULT_IDLE_TIMEOUT_S),
            retention_hours: self.retention_hours.unwrap_or(if clinical { CLINICAL_RETENTION_HOURS } else { 0 }),
            usb_export: self.usb_export.unwrap_or(!clinical),
            receive: EffectiveReceive {
                enabled: self.receive.enabled.unwrap_or(clinical),
                ae_title: self.receive.ae_title.clone(),
                port: self.receive.port,
                allowed_aes: self.receive.allowed_aes.clone(),
            },
            pacs: self.pacs.clone(),
            panel: self.panel.clone(),
        }
    }

    /// Every value within its rules; the first that is not, by its key.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let bad = |key: &str, problem: String| Err(SettingsError::Value { key: key.into(), problem });
        if let Some(seconds) = self.idle_timeout_s.filter(|&seconds| seconds > MAX_IDLE_TIMEOUT_S) {
            return bad("idle_timeout_s", format!("{seconds} is more than a day ({MAX_IDLE_TIMEOUT_S} s)"));
        }
        if let Some(hours) = self.retention_hours.filter(|&hours| hours > MAX_RETENTION_HOURS) {
            return bad("retention_hours", format!("{hours} is more than a year ({MAX_RETENTION_HOURS} h)"));
        }
        if let Err(error) = volasso_dicom::receive::check_ae_title(&self.receive.ae_title) {
            return bad("receive.ae_title", format!("{:?} {error}", self.receive.ae_title));
        }
        if self.receive.port == 0 {
            return bad("receive.port", "must be from 1 to 65535".into());
        }
        for title in &self.receive.allowed_aes {
            if let Err(error) = volasso_dicom::receive::check_ae_title(title) {
                return bad("receive.allowed_aes", format!("{title:?} {error}"));
            }
        }
        for peer in &self.pacs {
            if let Err(error) = volasso_dicom::pacs::Peer::parse(peer, &self.receive.ae_title, PACS_TIMEOUT) {
                return bad("pacs", error.to_string());
            }
        }
        if ![0, 90, 180, 270].contains(&self.panel.rotation_degrees) {
            return bad("panel.rotation_degrees", format!("{} is not 0, 90, 180 or 270", self.panel.rotation_degrees));
        }
        if let Some(dpi) = self.panel.dpi.filter(|dpi| !(40.0..=600.0).contains(dpi)) {
            return bad("panel.dpi", format!("{dpi} is not from 40 to 600"));
        }
        Ok(())
    }

    /// Changes the setting `key` to `value` as typed (`default` puts back the mode's default
    /// where a setting has one); the whole is validated after the change.
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), SettingsError> {
        let bad = |problem: &str| SettingsError::Value { key: key.into(), problem: format!("{value:?} {problem}") };
        let number = |most: u64| -> Result<u64, SettingsError> {
            value
                .trim()
                .parse::<u64>()
                .ok()
                .filter(|&n| n <= most)
                .ok_or_else(|| bad(&format!("is not a whole number from 0 to {most}")))
        };
        let flag = || -> Result<Option<bool>, SettingsError> {
            match value.trim() {
                "true" | "on" | "yes" => Ok(Some(true)),
                "false" | "off" | "no" => Ok(Some(false)),
                "default" => Ok(None),
                _ => Err(bad("is not true, false or default")),
            }
        };
        let list = || -> Vec<String> {
            value.split(',').map(str::trim).filter(|item| !item.is_empty()).map(String::from).collect()
        };
        let mut changed = self.clone();
        match key {
            "mode" => {
                changed.mode = match value.trim() {
                    "clinical" => Mode::Clinical,
                    "demo" => Mode::Demo,
                    _ => return Err(bad("is not clinical or demo")),
                }
            }
            "language" => {
                changed.language = match value.trim() {
                    "en" => Language::En,
                    "de" => Language::De,
                    _ => return Err(bad("is not en or de")),
                }
            }
            "idle_timeout_s" if value.trim() == "default" => changed.idle_timeout_s = None,
            "idle_timeout_s" => changed.idle_timeout_s = Some(number(MAX_IDLE_TIMEOUT_S)?),
            "retention_hours" if value.trim() == "default" => changed.retention_hours = None,
            "retention_hours" => changed.retention_hours = Some(number(MAX_RETENTION_HOURS)?),
            "usb_export" => changed.usb_export = flag()?,
            "receive.enabled" => changed.receive.enabled = flag()?,
            "receive.ae_title" => changed.receive.ae_title = value.trim().to_string(),
            "receive.port" => {
                changed.receive.port = value
                    .trim()
                    .parse()
                    .ok()
                    .filter(|&port| port > 0)
                    .ok_or_else(|| bad("is not a port from 1 to 65535"))?
            }
            "receive.allowed_aes" => changed.receive.allowed_aes = list(),
            "pacs" => changed.pacs = list(),
            "panel.rotation_degrees" => {
                changed.panel.rotation_degrees = value.trim().parse().map_err(|_| bad("is not 0, 90, 180 or 270"))?
            }
            "panel.dpi" if value.trim() == "default" => changed.panel.dpi = None,
            "panel.dpi" => changed.panel.dpi = Some(value.trim().parse().map_err(|_| bad("is not a number"))?),
            _ => return Err(SettingsError::UnknownKey { key: key.into() }),
        }
        changed.validate()?;
        *self = changed;
        Ok(())
    }
}

/// The keys [`Settings::set`] takes.
pub const KEYS: [&str; 12] = [
    "mode",
    "language",
    "idle_timeout_s",
    "retention_hours",
    "usb_export",
    "receive.enabled",
    "receive.ae_title",
    "receive.port",
    "receive.allowed_aes",
    "pacs",
    "panel.rotation_degrees",
    "panel.dpi",
];

/// The settings file of the data folder `data_dir`.
pub fn path(data_dir: &Path) -> PathBuf {
    data_dir.join(FILE)
}

/// Settings as read: the file's, or the safe defaults with why the file could not be used.
#[derive(Debug)]
pub struct Loaded {
    pub settings: Settings,
    /// Why the file was not used (its settings are the defaults then); `None` when it was, or
    /// when there is none (a first start).
    pub problem: Option<SettingsError>,
}

/// The settings of `data_dir`: the file's when it reads and every value is valid; the defaults
/// without a file; the defaults and the reason otherwise (nothing of a bad file is applied; the
/// caller says so, once).
pub fn load(data_dir: &Path) -> Loaded {
    match read(data_dir) {
        Ok(settings) => Loaded { settings: settings.unwrap_or_default(), problem: None },
        Err(problem) => Loaded { settings: Settings::default(), problem: Some(problem) },
    }
}

/// The settings file of `data_dir`, checked; `None` when there is none.
pub fn read(data_dir: &Path) -> Result<Option<Settings>, SettingsError> {
    let path = path(data_dir);
    let text = match std::fs::metadata(&path) {
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(SettingsError::Read { source, path }),
        Ok(meta) if meta.len() > MAX_FILE_BYTES => return Err(SettingsError::TooLarge { bytes: meta.len(), path }),
        Ok(_) => std::fs::read(&path).map_err(|source| SettingsError::Read { source, path: path.clone() })?,
    };
    let text = String::from_utf8(text)
        .map_err(|_| SettingsError::Parse { message: "it is not UTF-8 text".into(), path: path.clone() })?;
    let settings: Settings = toml::from_str(&text).map_err(|error| {
        let line = error.span().map(|span| text[..span.start.min(text.len())].matches('\n').count() + 1);
        let at = line.map_or(String::new(), |line| format!(" at line {line}"));
        SettingsError::Parse { message: format!("{}{at}", error.message().trim_end()), path: path.clone() }
    })?;
    settings.validate()?;
    Ok(Some(settings))
}

/// Writes `settings` as the settings file of `data_dir`, atomically, readable by the file's
/// group (on the appliance the receiver, another user of the kiosk's group, reads it).
pub fn write(data_dir: &Path, settings: &Settings) -> Result<(), SettingsError> {
    let path = path(data_dir);
    let text = toml::to_string(settings)
        .map_err(|error| SettingsError::Parse { message: error.to_string(), path: path.clone() })?;
    let header = "# volasso appliance settings (docs/interfaces.md); `volasso settings set KEY VALUE` changes one.\n";
    write_atomically(&path, |file| {
        use std::io::Write;
        file.write_all(header.as_bytes())?;
        file.write_all(text.as_bytes())
    })
    .map_err(|source| SettingsError::Write { source, path: path.clone() })?;
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640))
        .map_err(|source| SettingsError::Write { source, path })
}

#[cfg(test)]
mod tests;
