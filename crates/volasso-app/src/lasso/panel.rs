//! What a slice panel shows, as plain data: its numbers, title, edge letters, the lasso path
//! being drawn and the feedback on it ([`PanelShown`]); its picture (the grey slice, the
//! classes, the lassos, the unsure stripes, arranged for the screen) is asked of the painter.
//!
//! Never: touches the window; `view` writes a [`PanelShown`] into a slice row.

use crate::model::AppModel;
use crate::painter::PictureRequest;
use crate::pictures::class_colour;
use std::sync::Arc;

/// One panel as the screen shows it (its picture comes from the painter).
pub(crate) struct PanelShown {
    /// The axis's name (`z`, `y`, `x`).
    pub axis: &'static str,
    /// The plane (Axial, Coronal, Sagittal) or "Slice AXIS", in English.
    pub title: String,
    /// The patient's orientation is known.
    pub oriented: bool,
    pub slice: i32,
    /// Slices along the axis.
    pub count: i32,
    /// The slice's rank in the axis's entropy ranking, from 1.
    pub rank: i32,
    /// Width over height of the slice on screen.
    pub aspect: f32,
    /// The finger path being drawn on this panel, as SVG path commands.
    pub lasso: String,
    /// Top, right, bottom and left edge letters (empty when unknown).
    pub letters: [&'static str; 4],
    /// The message on the panel, in English.
    pub feedback: String,
    /// The picture shown until the new one comes may stay: the panel shows the same volume
    /// along the same axis (never another scan's slice).
    pub keep_picture: bool,
}

impl AppModel {
    /// What `panel` shows, its new picture asked of the painter; `None` without a scan open or
    /// such a panel.
    pub(crate) fn panel_shown(&mut self, panel: usize) -> Option<PanelShown> {
        let work = self.ctl.work.as_ref()?;
        let shown = work.panels.get(panel)?;
        let volume = &work.loaded.volume;
        let styles = self.ctl.display_styles();
        let classification = work.classified.as_ref().zip(styles).map(|(c, s)| (c.labels.clone(), s));
        let (template, total, next) =
            (self.ctl.template(), self.ctl.training_class_count(), work.session.classes.len());
        let mut highlights = Vec::new();
        if classification.is_none() {
            for (index, class) in work.session.classes.iter().enumerate() {
                highlights.push((class.lassos.clone(), class_colour(None, &template, index, total)));
            }
        }
        highlights.push((work.session.pending.clone(), class_colour(None, &template, next, next + 1)));
        let layout = shown.layout;
        let request = PictureRequest {
            panel,
            volume: volume.clone(),
            layout,
            slice: shown.slice,
            window: work.window,
            classification,
            highlights,
            clip: self.ctl.look.clip,
            unsure: (work.guidance().filter(|_| work.unsure_shown))
                .map(|guidance| (guidance.segmenter.clone(), guidance.survey.threshold)),
        };
        let [across_mm, down_mm] = layout.screen_extent_mm(volume.dims, volume.spacing_mm);
        let letters = layout.edge_letters.map_or([""; 4], |l| [l.top, l.right, l.bottom, l.left]);
        let on_panel = |on: usize| on == panel;
        let same_picture = (Arc::as_ptr(volume) as usize, shown.axis);
        let panel_shown = PanelShown {
            axis: shown.axis.name(),
            title: layout.plane.map_or_else(|| format!("Slice {}", shown.axis), |plane| plane.name().to_string()),
            oriented: layout.plane.is_some(),
            slice: shown.slice as i32,
            count: volume.dims[shown.axis.position()] as i32,
            rank: shown.rank as i32 + 1,
            aspect: (across_mm / down_mm.max(1e-9)) as f32,
            lasso: work
                .drawing
                .as_ref()
                .filter(|(on, _)| on_panel(*on))
                .map_or(String::new(), |(_, p)| p.svg_commands()),
            letters,
            feedback: work.feedback.as_ref().filter(|(on, _)| on_panel(*on)).map_or(String::new(), |(_, m)| m.clone()),
            keep_picture: self.panel_pictures.get(panel) == Some(&same_picture),
        };
        if self.panel_pictures.len() <= panel {
            self.panel_pictures.resize(panel + 1, same_picture);
        }
        self.panel_pictures[panel] = same_picture;
        self.painter.request(request);
        Some(panel_shown)
    }
}
