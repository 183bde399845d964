//! The appliance's policies, shared by the kiosk, the receiver and the command line: the
//! settings an installer chooses (`settings`: one TOML file in the data folder, validated, on
//! safe defaults when it cannot be read), the PIN that guards the settings screen (`pin`), the
//! audit log hospital IT reads (`audit`), and the patient data that expires (`retention`).
//!
//! Never: draws, talks to the network, or reads a patient's data.

pub mod audit;
pub mod pin;
pub mod retention;
pub mod settings;
