//! Integration tests, one binary (as ripgrep's `tests/tests.rs`). What belongs where:
//!
//! * `formats`: every volume in `../shared/data` opens with the right dimensions, type, spacing
//!   and values (checked against figures computed independently with numpy).
//! * `malformed`: broken, truncated and lying files each give one clear error, never a panic.
//! * `mutations`: a short fuzz pass (seeded mutations of `fuzz/seeds`) through every reader,
//!   in a process of its own so that its allocations can be counted.
//! * `hostile`: files built to exhaust memory or reach outside their folder (bombs, wrapping
//!   skips, device data files, edited DICOM) give one clear error each within 300 MB.
//! * `hostile_values`: header values generated per format and field (absurd spacings, fields
//!   given twice, byte-order flags, ASCII values out of range, NIfTI series and scalings,
//!   trailing bytes, non-finite volumes) give one clear error or the sensible volume and warning.
//! * `hostile_cli`: hostile use of the command line and the kiosk (outputs that name inputs,
//!   strokes and scripts that are FIFOs, devices or not UTF-8, zig-zag and repeated loops,
//!   255 classes, constant volumes, camera options out of range, a failed classification's
//!   banner), each within 30 s and 1 GB; the 12-class kiosk under a 3 GB address-space limit
//!   is `.ci/memory`'s (over a minute).
//! * `architecture`: no file of the app imports a file that imports it back.
//! * `accuracy`: the accuracy harness on small phantoms: the default classifier
//!   beats a random forest on the paper's features and is not below the plain SVM.
//! * `classification`: accuracy on the demo phantom, coarse-to-fine against exact, loops in a
//!   real scan's blurred edge (`tests/strokes`) that leave the air background, and
//!   `volasso classify`'s contract and errors.
//! * `cli`: the `volasso` binary's contracts from `interfaces.md` (exit codes, output, atomic
//!   writes).
//! * `rendering`: what `volasso render` draws with the default class table (every class seen).
//! * `replay`: the kiosk UI driven by touch scripts through `volasso replay`;
//!   `replay_gallery`: the same for kept results and attract mode; `replay_sessions`: hostile
//!   files in the data folder and saved sessions that fail, stop the app or classify.
//! * `deploy`: the appliance's scripts that run outside the image (the USB import).
//! * `dicom_codecs`: compressed (dcmtk's JPEG lossless, JPEG-LS, RLE, deflate) and enhanced
//!   multi-frame DICOM read to the voxels of the uncompressed series; the series listing.
//! * `dicom_jpeg2000`: JPEG 2000 lossless DICOM (encoded here with OpenJPEG) reads to the same
//!   voxels.
//! * `dicom_receive`: `volasso receive` against dcmtk's storescu and echoscu (store, replace,
//!   several series, a killed association, refusals); a series published whole or not at all,
//!   also across kills of the receiver; failures told to the sender; limits and timeouts
//!   against hostile peers; TLS.
//! * `dicom_export`: `volasso export` writes a DICOM Segmentation and a Secondary Capture of the
//!   classified Philips series that dciodvfy validates and highdicom reads back voxel for voxel;
//!   labels that do not belong to the series are refused.
//! * `replay_pacs`: the PACS screen and "Send to PACS" by touch against Orthanc on loopback,
//!   and a PACS that is down.
//! * `pacs`: `volasso pacs find|get|send` against Orthanc started on loopback: the Philips
//!   series found, retrieved voxel for voxel, classified, exported and sent back into its study;
//!   a PACS that is down, rejects the association or fails a C-STORE.
//! * `settings`: `volasso settings show|set` and `volasso audit`: the settings in effect, one
//!   clear line for a bad key or value, a damaged file shown as the safe defaults and kept.
//! * `library`: the array entry of the pipeline labels as `volasso classify` does.
//! * `support`: shared fixtures (paths, running the binary, writing test files).

mod accuracy;
mod architecture;
mod classification;
mod cli;
mod deploy;
mod dicom_codecs;
mod dicom_export;
mod dicom_jpeg2000;
mod dicom_receive;
mod formats;
mod hostile;
mod hostile_cli;
mod hostile_values;
mod library;
mod malformed;
mod mutations;
mod pacs;
mod rendering;
mod replay;
mod replay_gallery;
mod replay_pacs;
mod replay_sessions;
mod settings;
mod support;
