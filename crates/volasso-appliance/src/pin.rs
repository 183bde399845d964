//! The PIN that guards the settings screen: 4 to 8 digits, chosen at the first start, kept in
//! the data folder's `pin` file as a salted Argon2 hash (a PHC string), never as typed. A wrong
//! PIN is refused; after [`FREE_TRIES`] wrong ones in a row every further try waits
//! [`LOCKOUT`], doubled at each wrong PIN after it (a 4-digit PIN falls to guessing otherwise).
//!
//! Never: writes the PIN itself anywhere, or accepts a PIN when its file cannot be read (the
//! installer replaces the file, `volasso settings --data-dir DIR set-pin`).

use argon2::Argon2;
use argon2::password_hash::{PasswordHash, PasswordHasher, PasswordVerifier, SaltString, rand_core::OsRng};
use std::path::{Path, PathBuf};
use std::time::Duration;
use volasso_core::atomic_file::write_atomically;

/// The file's name in the data folder.
pub const FILE: &str = "pin";
/// Wrong PINs in a row allowed before the wait.
pub const FREE_TRIES: u32 = 3;
/// The first wait after [`FREE_TRIES`] wrong PINs.
pub const LOCKOUT: Duration = Duration::from_secs(30);
/// The longest wait.
const MOST_LOCKOUT: Duration = Duration::from_secs(3600);

/// Why a PIN cannot be set or checked.
#[derive(Debug, thiserror::Error)]
pub enum PinError {
    #[error("a PIN is 4 to 8 digits")]
    Form,
    #[error("cannot read the PIN file: {message}, in {}", path.display())]
    Read { message: String, path: PathBuf },
    #[error("cannot write the PIN file: {source}, in {}", path.display())]
    Write { source: std::io::Error, path: PathBuf },
}

/// What a PIN typed gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Accepted,
    /// Wrong; this many more wrong PINs before the wait.
    Refused {
        tries_left: u32,
    },
    /// Not checked: try again after this long.
    Wait(Duration),
    /// No PIN is set yet (the first start): one is to be chosen.
    NotSet,
}

/// Wrong PINs in a row and when the next try is allowed, on the caller's clock.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Attempts {
    wrong: u32,
    next_try: Duration,
}

impl Attempts {
    /// How long before the next PIN may be tried, at `now`.
    pub fn wait(&self, now: Duration) -> Duration {
        self.next_try.saturating_sub(now)
    }
}

/// Whether `text` is a PIN's form.
pub fn well_formed(text: &str) -> bool {
    (4..=8).contains(&text.len()) && text.bytes().all(|byte| byte.is_ascii_digit())
}

/// The PIN file of `data_dir`.
pub fn path(data_dir: &Path) -> PathBuf {
    data_dir.join(FILE)
}

/// Whether a PIN was chosen.
pub fn is_set(data_dir: &Path) -> bool {
    path(data_dir).exists()
}

/// Chooses `pin` (its salted hash replaces the file, atomically).
pub fn set(data_dir: &Path, pin: &str) -> Result<(), PinError> {
    if !well_formed(pin) {
        return Err(PinError::Form);
    }
    let path = path(data_dir);
    let salt = SaltString::generate(&mut OsRng);
    let hash = Argon2::default()
        .hash_password(pin.as_bytes(), &salt)
        .map_err(|error| PinError::Write { source: std::io::Error::other(error.to_string()), path: path.clone() })?
        .to_string();
    write_atomically(&path, |file| {
        use std::io::Write;
        writeln!(file, "{hash}")
    })
    .map_err(|source| PinError::Write { source, path })
}

/// Checks `pin` at `now` (the caller's clock), counting wrong PINs in `attempts`.
pub fn check(data_dir: &Path, pin: &str, attempts: &mut Attempts, now: Duration) -> Result<Verdict, PinError> {
    let path = path(data_dir);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => return Ok(Verdict::NotSet),
        Err(error) => return Err(PinError::Read { message: error.to_string(), path }),
    };
    let hash = PasswordHash::new(text.trim()).map_err(|error| PinError::Read { message: error.to_string(), path })?;
    if now < attempts.next_try {
        return Ok(Verdict::Wait(attempts.next_try - now));
    }
    if well_formed(pin) && Argon2::default().verify_password(pin.as_bytes(), &hash).is_ok() {
        *attempts = Attempts::default();
        return Ok(Verdict::Accepted);
    }
    attempts.wrong += 1;
    if attempts.wrong < FREE_TRIES {
        return Ok(Verdict::Refused { tries_left: FREE_TRIES - attempts.wrong });
    }
    let doublings = (attempts.wrong - FREE_TRIES).min(16);
    attempts.next_try = now + (LOCKOUT * 2u32.pow(doublings)).min(MOST_LOCKOUT);
    Ok(Verdict::Refused { tries_left: 0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chosen_pin_is_accepted_and_kept_only_as_a_salted_hash() {
        let data = tempfile::tempdir().unwrap();
        let mut attempts = Attempts::default();
        assert_eq!(check(data.path(), "1234", &mut attempts, Duration::ZERO).unwrap(), Verdict::NotSet);
        assert!(!is_set(data.path()));
        set(data.path(), "4711").unwrap();
        assert!(is_set(data.path()));
        let stored = std::fs::read_to_string(path(data.path())).unwrap();
        assert!(stored.starts_with("$argon2") && !stored.contains("4711"), "{stored}");
        assert_eq!(check(data.path(), "4711", &mut attempts, Duration::ZERO).unwrap(), Verdict::Accepted);
        // The same PIN chosen again hashes with another salt.
        set(data.path(), "4711").unwrap();
        assert_ne!(std::fs::read_to_string(path(data.path())).unwrap(), stored);
    }

    #[test]
    fn wrong_pins_are_refused_and_after_three_each_try_waits_longer() {
        let data = tempfile::tempdir().unwrap();
        set(data.path(), "4711").unwrap();
        let mut attempts = Attempts::default();
        let at = |seconds: u64| Duration::from_secs(seconds);
        assert_eq!(check(data.path(), "0000", &mut attempts, at(0)).unwrap(), Verdict::Refused { tries_left: 2 });
        assert_eq!(check(data.path(), "12", &mut attempts, at(1)).unwrap(), Verdict::Refused { tries_left: 1 });
        assert_eq!(check(data.path(), "1111", &mut attempts, at(2)).unwrap(), Verdict::Refused { tries_left: 0 });
        // Locked for 30 s: even the right PIN waits.
        assert_eq!(check(data.path(), "4711", &mut attempts, at(12)).unwrap(), Verdict::Wait(at(20)));
        assert_eq!(check(data.path(), "2222", &mut attempts, at(32)).unwrap(), Verdict::Refused { tries_left: 0 });
        assert_eq!(check(data.path(), "4711", &mut attempts, at(33)).unwrap(), Verdict::Wait(at(59)), "60 s now");
        assert_eq!(check(data.path(), "4711", &mut attempts, at(92)).unwrap(), Verdict::Accepted);
        assert_eq!(attempts, Attempts::default(), "the count starts again");
    }

    #[test]
    fn a_pin_of_another_form_is_not_chosen_and_a_damaged_file_accepts_nothing() {
        let data = tempfile::tempdir().unwrap();
        for pin in ["123", "123456789", "12a4", "", " 1234"] {
            assert!(matches!(set(data.path(), pin), Err(PinError::Form)), "{pin:?}");
        }
        std::fs::write(path(data.path()), "4711\n").unwrap();
        let error = check(data.path(), "4711", &mut Attempts::default(), Duration::ZERO).unwrap_err();
        assert!(error.to_string().contains("cannot read the PIN file"), "{error}");
    }
}
