//! The attract mode as the app model applies it: started where the start screen comes back,
//! ended where it is left, ticked by the poll.
//!
//! Never: renders on the caller's thread.

use super::what_to_show;
use crate::model::{AppModel, AttractShow, Show};

impl AppModel {
    /// The start screen came back: the turntable starts (when there is something to show).
    pub(crate) fn begin_attract(&mut self) -> Show {
        let Some(showing) = what_to_show(self.config.data_dir.as_deref()) else {
            return Show::default();
        };
        let (options, now) = (self.config.open_options.clone(), self.config.clock.now());
        self.attract.begin(showing, self.attract_side, options, now);
        Show { attract: Some(AttractShow::Begin), ..Default::default() }
    }

    /// The start screen is left: the turntable stops.
    pub(crate) fn end_attract(&mut self) -> Show {
        self.attract.end();
        Show { attract: Some(AttractShow::End), ..Default::default() }
    }

    /// The poll's tick: the model moves on, and a picture that is due is shown.
    pub(crate) fn tick_attract(&mut self) -> Show {
        let now = self.config.clock.now();
        let attract = self.attract.tick(now).map(AttractShow::Frame);
        Show { attract, ..Default::default() }
    }
}
