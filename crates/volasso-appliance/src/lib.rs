//! The appliance's policies, shared by the kiosk, the receiver and the command line: the
//! settings an installer chooses (`settings`: one TOML file in the data folder, validated, on
//! safe defaults when it cannot be read) and the audit log hospital IT reads (`audit`).
//!
//! Never: draws, talks to the network, or reads a patient's data.

pub mod audit;
pub mod settings;
