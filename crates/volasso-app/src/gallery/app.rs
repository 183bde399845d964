//! The gallery as the app model applies it: "Save", a kept result's card tapped, a finished
//! save collected and the opened result's camera and visibility put back.
//!
//! Never: writes on the caller's thread (the model's writer does).

use crate::gallery::model::CurrentResult;
use crate::model::{AppModel, Show};

impl AppModel {
    /// Lists the gallery again (the chooser's result cards).
    pub(crate) fn relist_gallery(&mut self) -> Show {
        self.gallery.relist(self.config.data_dir.as_deref());
        Show { results: true, ..Show::default() }
    }

    /// "Save": the current result and the 3-D view's newest picture to the gallery.
    pub(crate) fn save_result(&mut self) -> Show {
        let saved_unix =
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |since| since.as_secs());
        let current = self.current_result();
        let picture = self.view_picture.clone();
        self.status = self.gallery.save(self.config.data_dir.as_deref(), current, picture, saved_unix);
        Show::status()
    }

    /// The result on the work screen, when a scan is open.
    fn current_result(&self) -> Option<CurrentResult> {
        let work = self.ctl.work.as_ref()?;
        Some(CurrentResult {
            session: self.ctl.saved_session()?,
            volume_name: work.loaded.source.name(),
            classified: work.classified.is_some(),
            camera: self.view.camera,
            visible: work.session.classes.iter().map(|class| class.visible).collect(),
        })
    }

    /// Collects a finished save, and puts back a result's camera and visibility once its
    /// volume is the open one.
    pub(crate) fn poll_gallery(&mut self) -> Show {
        let mut show = Show::default();
        if let Some(status) = self.gallery.poll() {
            self.status = status;
            show = self.relist_gallery().and(Show::status());
        }
        let open_key = self.ctl.work.as_ref().map(|work| work.loaded.source.key());
        let Some(look) = self.gallery.look_to_put_back(self.opening.is_some(), open_key.as_deref()) else {
            return show;
        };
        self.view.camera = look.camera;
        self.view.dirty = true;
        for (index, shown) in look.visible.into_iter().enumerate() {
            let class_shown = self.ctl.work.as_ref().and_then(|w| w.session.classes.get(index)).map(|c| c.visible);
            if class_shown == Some(!shown) {
                let changed = self.ctl.toggle_class(index);
                show = show.and(self.changed(changed));
            }
        }
        show
    }

    /// A result card tapped: its volume opens with its classes; its camera and visibility
    /// follow ([`poll_gallery`](Self::poll_gallery)).
    pub(crate) fn open_result(&mut self, index: usize) -> Show {
        if self.opening.is_some() {
            return Show::default();
        }
        match self.gallery.open(index) {
            None => Show::default(),
            Some(Err(message)) => {
                self.status = message;
                Show::status()
            }
            Some(Ok(opening)) => {
                // A scan outside the data folder joins the chooser, so indices stay aligned.
                let index = self.add_source(opening.source.clone());
                self.restore = Some(opening.session);
                self.start_opening(index, opening.source, &opening.volume_name);
                Show { status: true, cards: true, ..Show::default() }
            }
        }
    }
}
