//! The app's state by name, for replay scripts' `expect KEY VALUE` ([`super::App::query`]):
//! `screen` (start, chooser, work, pacs, settings), `classes`, `pending`, `volume`, `patient` (the work
//! screen's patient line; empty in demo mode), `banner`, `hint` (the line
//! over an empty 3-D view), `failed` (`yes` while the newest classification failed), `busy`,
//! `classifying`, `classified`, `template`, `slice-z` / `slice-y` / `slice-x`, `cards` (the
//! chooser's cards), `cannot-open` (those whose file cannot be opened), `panels` (the panels'
//! axes, e.g. `z,y,x`), `plane-z` / `-y` / `-x` (Axial, Coronal, Sagittal or unknown),
//! `letters-z` / `-y` / `-x` (top, right, bottom, left, e.g. `A,L,P,R`; empty when unknown),
//! `window` (e.g. `Brain W80 L40`), `enlarged` (an axis or `none`), `zoom`, `feedback` (the
//! message on a panel), `camera` (azimuth and elevation in degrees), `label-uploads`
//! (classifications sent to the 3-D view: a restyle or a first look sends none), `opacity` (each class's opacity in
//! percent, e.g. `100,40`), `clip` (`off`, or the plane's normal and offset in mm), `results`
//! (the gallery's cards), `result-problem-N` (why card N, from 1, cannot be opened; empty
//! when it can), `attract` (the start screen's turntable: off, loading, rendering or
//! playing), `unsure` (`on` while the unsure voxels are striped, else `off`),
//! `unsure-share` (the unsure share of the classified voxels in percent) and
//! `on-unsure-slice` (`yes` when the panel "Draw here next" picks shows the slice it picks);
//! `studies` (the PACS list's rows), `pacs` (the PACS screen's status line), `pacs-failed`
//! (`yes` when its last search or retrieval failed), `sent` (the answer of "Send to PACS") and
//! `send-failed` (`yes` when that answer is a failure); `pin-message` (what the PIN keypad
//! says of the last PIN) and `setting.KEY` (a settings row's value in words, e.g.
//! `setting.mode`), `expires-N` (when card N, from 1, is deleted as expired; empty when it
//! is not).
//!
//! [`result_digest`] is what a result is, in one line (replay's `same-result`).
//!
//! Never: changes anything.

use super::gallery::view as results;
use super::{State, windowing};
use volasso_core::slices::Axis;

pub(super) fn query(state: &State, key: &str) -> Option<String> {
    let screen = state.screen as usize;
    let work = state.ctl.work.as_ref();
    let value = match key {
        "screen" => ["start", "chooser", "work", "pacs", "settings"].get(screen).unwrap_or(&"?").to_string(),
        "classes" => work.map_or(0, |w| w.session.classes.len()).to_string(),
        "pending" => work.map_or(0, |w| w.session.pending.len()).to_string(),
        "volume" => work.map_or(String::new(), |w| w.loaded.source.name()),
        "patient" => work.map_or(String::new(), |w| w.loaded.patient.line()),
        "banner" => state.banner.clone(),
        "status" => state.status.clone(),
        "presets" => state.presets.shelf.names().len().to_string(),
        "preset" => work.and_then(|w| w.preset.as_ref()).map_or(String::new(), |preset| preset.name.clone()),
        "pin-message" => match &state.settings.phase {
            super::settings::Phase::Pin(entry) => entry.message.clone(),
            _ => String::new(),
        },
        key if key.starts_with("setting.") => {
            let rows = state.settings.rows();
            rows.into_iter().find(|row| Some(row.key) == key.strip_prefix("setting.")).map(|row| row.value)?
        }
        "hint" => state.ctl.view_hint().to_string(),
        "failed" => if state.ctl.failure().is_some() { "yes" } else { "no" }.to_string(),
        "busy" => (state.ctl.jobs.busy() || state.opening.is_some()).to_string(),
        "classifying" => state.ctl.jobs.busy().to_string(),
        "classified" => work.and_then(|w| w.classified.as_ref()).map_or(0, |c| c.table.styles.len()).to_string(),
        "cards" => state.cards.len().to_string(),
        "studies" => state.pacs.model.rows().len().to_string(),
        "pacs" => state.pacs.model.message.clone(),
        "sent" => state.pacs.model.send_message.clone(),
        "pacs-failed" => yes_no(state.pacs.model.failed()),
        "send-failed" => yes_no(state.pacs.model.send_message.starts_with("Not sent")),
        "cannot-open" => state.cards.failed().to_string(),
        "template" => {
            let template = state.ctl.template();
            format!("{} {}", template.template.name(), template.rotation_degrees)
        }
        "panels" => work.map_or(String::new(), |w| w.panels.map(|p| p.axis.name()).join(",")),
        "window" => work.map_or(String::new(), |w| windowing::describe(&w.window_name, w.window)),
        "enlarged" => {
            work.and_then(|w| w.enlarged).and_then(|p| work?.panels.get(p)).map_or("none", |p| p.axis.name()).into()
        }
        "zoom" => format!("{:.1}", work.map_or(1.0, |w| w.zoom)),
        "feedback" => work.and_then(|w| w.feedback.as_ref()).map_or(String::new(), |(_, m)| m.clone()),
        "camera" => format!("{:.1} {:.1}", state.view.camera.azimuth_degrees, state.view.camera.elevation_degrees),
        "label-uploads" => state.ctl.renderer.label_uploads().to_string(),
        "clip" => state.ctl.look.clip.map_or("off".to_string(), |plane| {
            let [x, y, z] = plane.normal;
            format!("{x:.2},{y:.2},{z:.2} {:.1}", plane.offset_mm)
        }),
        "opacity" => {
            let classes = work.map_or(0, |w| w.session.classes.len());
            let percent = |index| format!("{:.0}", state.ctl.class_opacity(index) * 100.0);
            (0..classes).map(percent).collect::<Vec<_>>().join(",")
        }
        "attract" => state.attract.describe().to_string(),
        "unsure" => if work.is_some_and(|w| w.unsure_shown) { "on" } else { "off" }.to_string(),
        "on-unsure-slice" => {
            let (panel, slice, _) = super::guidance::next_place(work?)?;
            if work?.panels[panel].slice == slice { "yes" } else { "no" }.to_string()
        }
        "unsure-share" => {
            let guidance = work?.guidance()?;
            format!("{:.0}", 100.0 * guidance.survey.unsure_fraction())
        }
        key if key.starts_with("result") => results::query(state, key)?,
        key if key.starts_with("expires-") => {
            let card: usize = key.strip_prefix("expires-")?.parse().ok()?;
            state.cards.card(card.checked_sub(1)?)?.expires.clone()
        }
        _ => {
            let (kind, axis) = key.rsplit_once('-')?;
            let panel = work?.panels.iter().find(|panel| Some(panel.axis) == Axis::from_name(axis))?;
            match kind {
                "slice" => panel.slice.to_string(),
                "plane" => panel.layout.plane.map_or("unknown", |plane| plane.name()).to_string(),
                "letters" => {
                    panel.layout.edge_letters.map_or(String::new(), |l| [l.top, l.right, l.bottom, l.left].join(","))
                }
                _ => return None,
            }
        }
    };
    Some(value)
}

/// What a result is, in one line (replay's `same-result`): the volume, each class's name
/// and visibility, the template, a digest of the label volume shown, and the camera.
pub(super) fn result_digest(state: &State) -> String {
    let Some(work) = state.ctl.work.as_ref() else { return "no volume".into() };
    let classes: Vec<String> = work
        .session
        .classes
        .iter()
        .map(|c| format!("{}{}", c.name, if c.visible { "" } else { " (hidden)" }))
        .collect();
    // FNV-1a over the labels: equal label volumes, equal digests.
    let labels = work.classified.as_ref().map_or(0, |classified| {
        classified.labels.iter().fold(0xcbf2_9ce4_8422_2325u64, |hash, &label| {
            (hash ^ u64::from(label)).wrapping_mul(0x0000_0100_0000_01b3)
        })
    });
    let template = state.ctl.template();
    let camera = &state.view.camera;
    format!(
        "{}; classes {}; template {} {}; labels {labels:016x}; camera {:.1} {:.1} {:.2} {:.1},{:.1}",
        work.loaded.source.key(),
        classes.join(", "),
        template.template.name(),
        template.rotation_degrees,
        camera.azimuth_degrees,
        camera.elevation_degrees,
        camera.zoom,
        camera.pan_mm[0],
        camera.pan_mm[1],
    )
}

fn yes_no(flag: bool) -> String {
    if flag { "yes" } else { "no" }.to_string()
}
