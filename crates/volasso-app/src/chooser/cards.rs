//! The chooser's cards as data: one per scan the chooser offers (the demo, then the data
//! folder's volumes and series), each with its name, its picture and size once made, whose
//! scan it is (clinical mode), or why it cannot be opened. What the loader reports and what the
//! data folder's listing finds change them here; loading.rs shows the rows that changed.
//!
//! Loader events name a card by its index, so cards are only appended while any is in flight;
//! the cards of scans that are gone (deleted as expired) are dropped, and the rest renumbered,
//! only when none is ([`Cards::drop_gone`]).
//!
//! Never: opens a file or touches Slint.

use super::library::{self, Thumbnail, VolumeSource};
use std::path::Path;
use std::time::{Duration, SystemTime};
use volasso_core::transfer::RgbImage;

/// One card.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Card {
    pub name: String,
    /// Size and voxel type; for a card that cannot be opened, why (a sentence).
    pub detail: String,
    /// Whose scan it is (clinical mode); empty when not shown or not yet read.
    pub patient: String,
    pub thumbnail: Option<RgbImage>,
    /// The scan cannot be opened: shown as such, and not tappable.
    pub failed: bool,
    /// When a received series is deleted as expired ("Deleted in 23 h"); empty for a scan that
    /// does not expire.
    pub expires: String,
}

/// Which cards changed since the view last showed them.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) enum Changes {
    #[default]
    None,
    /// These rows (an index at or past the shown rows is a new card).
    Rows(Vec<usize>),
    /// The cards were renumbered: show them all again.
    All,
}

/// The chooser's scans and their cards, in the same order.
#[derive(Debug, Default)]
pub(crate) struct Cards {
    sources: Vec<VolumeSource>,
    cards: Vec<Card>,
    changes: Changes,
}

impl Cards {
    /// Cards of `sources`, blank until their thumbnails come.
    pub(crate) fn new(sources: Vec<VolumeSource>) -> Cards {
        let cards = sources.iter().map(blank).collect();
        Cards { sources, cards, changes: Changes::All }
    }

    pub(crate) fn sources(&self) -> &[VolumeSource] {
        &self.sources
    }

    pub(crate) fn source(&self, index: usize) -> Option<&VolumeSource> {
        self.sources.get(index)
    }

    pub(crate) fn card(&self, index: usize) -> Option<&Card> {
        self.cards.get(index)
    }

    pub(crate) fn len(&self) -> usize {
        self.cards.len()
    }

    /// Cards whose scan cannot be opened.
    pub(crate) fn failed(&self) -> usize {
        self.cards.iter().filter(|card| card.failed).count()
    }

    /// The index of `source`, appended with a blank card when new (and whether it was).
    pub(crate) fn add(&mut self, source: VolumeSource) -> (usize, bool) {
        if let Some(index) = self.sources.iter().position(|known| *known == source) {
            return (index, false);
        }
        self.cards.push(blank(&source));
        self.sources.push(source);
        let index = self.sources.len() - 1;
        self.changed(index);
        (index, true)
    }

    /// The scans of `found` the cards lack, appended (with their indices).
    pub(crate) fn add_new(&mut self, found: Vec<VolumeSource>) -> Vec<(usize, VolumeSource)> {
        let added = library::appeared(&self.sources, found);
        for (_, source) in &added {
            self.add(source.clone());
        }
        added
    }

    /// The picture and words of card `index` came.
    pub(crate) fn thumbnail(&mut self, index: usize, thumbnail: Thumbnail) {
        let Some(card) = self.cards.get_mut(index) else { return };
        card.thumbnail = Some(thumbnail.image);
        card.detail = thumbnail.detail;
        if let Some(title) = thumbnail.title {
            card.name = title;
        }
        card.patient = thumbnail.patient;
        self.changed(index);
    }

    /// Card `index`'s scan cannot be opened, for `reason`: it says so ("Cannot open").
    pub(crate) fn failed_to_open(&mut self, index: usize, reason: &str) {
        let Some(card) = self.cards.get_mut(index) else { return };
        let mut characters = reason.chars();
        card.detail =
            characters.next().map(|first| first.to_uppercase().chain(characters).collect()).unwrap_or_default();
        card.failed = true;
        card.thumbnail = None;
        self.changed(index);
    }

    /// Card `index` is a folder of `count` series, each with a card of its own.
    pub(crate) fn folder_of_series(&mut self, index: usize, count: usize) {
        let Some(card) = self.cards.get_mut(index) else { return };
        card.detail = format!("{count} series, a card each");
        card.thumbnail = None;
        self.changed(index);
    }

    /// How many series of the folder `source` names have cards of their own.
    pub(crate) fn series_of(&self, source: &VolumeSource) -> usize {
        let VolumeSource::Path(path) = source else { return 0 };
        self.sources.iter().filter(|s| matches!(s, VolumeSource::Series { folder, .. } if folder == path)).count()
    }

    /// Drops the cards whose file or folder is gone; how many went. Call only while no loader
    /// event is in flight (the others are renumbered).
    pub(crate) fn drop_gone(&mut self) -> usize {
        let there = |source: &VolumeSource| source.path().is_none_or(Path::exists);
        let kept: Vec<bool> = self.sources.iter().map(there).collect();
        let gone = kept.iter().filter(|&&kept| !kept).count();
        if gone > 0 {
            let mut keep = kept.iter();
            self.sources.retain(|_| keep.next() == Some(&true));
            let mut keep = kept.iter();
            self.cards.retain(|_| keep.next() == Some(&true));
            self.changes = Changes::All;
        }
        gone
    }

    /// Each received series' card says when it is deleted with `retention` (none: nothing
    /// expires), as of `now` (the wall clock, as file times are).
    pub(crate) fn note_expiry(&mut self, retention: Option<Duration>, now: SystemTime) {
        for index in 0..self.cards.len() {
            let deleted_after = retention
                .zip(self.sources[index].path())
                .and_then(|(retention, path)| volasso_appliance::retention::series_deleted_after(path, retention));
            let text = deleted_after.map_or_else(String::new, |at| expiry_text(at, now));
            if self.cards[index].expires != text {
                self.cards[index].expires = text;
                self.changed(index);
            }
        }
    }

    /// What changed since the last call.
    pub(crate) fn take_changes(&mut self) -> Changes {
        std::mem::take(&mut self.changes)
    }

    fn changed(&mut self, index: usize) {
        match &mut self.changes {
            Changes::All => {}
            Changes::Rows(rows) => {
                if !rows.contains(&index) {
                    rows.push(index);
                }
            }
            none @ Changes::None => *none = Changes::Rows(vec![index]),
        }
    }
}

/// When a scan deleted after `at` goes, as of `now`, in hours from two hours on, else minutes.
fn expiry_text(at: SystemTime, now: SystemTime) -> String {
    let left = at.duration_since(now).unwrap_or_default().as_secs();
    match left {
        0..60 => "Deleted at the next sweep".into(),
        60..7200 => format!("Deleted in {} min", left / 60),
        _ => format!("Deleted in {} h", left / 3600),
    }
}

/// A card before its thumbnail: the scan's name.
fn blank(source: &VolumeSource) -> Card {
    Card { name: source.name(), ..Card::default() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn picture() -> RgbImage {
        RgbImage { width: 1, height: 1, pixels: vec![1, 2, 3] }
    }

    #[test]
    fn cards_fill_in_as_the_loader_reports_and_only_changed_rows_are_shown_again() {
        let mut cards = Cards::new(vec![VolumeSource::Demo, VolumeSource::Path("a.nrrd".into())]);
        assert_eq!(cards.take_changes(), Changes::All);
        assert_eq!(cards.take_changes(), Changes::None);
        let thumbnail = Thumbnail {
            image: picture(),
            detail: "2 x 2 x 2  uint8".into(),
            title: Some("STD BRAIN 5MM (CT, 28 images)".into()),
            patient: "HEAD · ID PLASTIC".into(),
        };
        cards.thumbnail(1, thumbnail);
        cards.failed_to_open(0, "the file is empty");
        assert_eq!(cards.take_changes(), Changes::Rows(vec![1, 0]));
        let card = cards.card(1).unwrap();
        assert_eq!(
            (card.name.as_str(), card.patient.as_str(), card.failed),
            ("STD BRAIN 5MM (CT, 28 images)", "HEAD · ID PLASTIC", false)
        );
        assert_eq!((cards.card(0).unwrap().detail.as_str(), cards.failed()), ("The file is empty", 1));
        // A scan retrieved from the PACS joins once; a known one keeps its index.
        assert_eq!(cards.add(VolumeSource::Path("b".into())), (2, true));
        assert_eq!(cards.add(VolumeSource::Path("a.nrrd".into())), (1, false));
        assert_eq!(cards.take_changes(), Changes::Rows(vec![2]));
        // Reports for a card that is not there change nothing.
        cards.thumbnail(9, Thumbnail { image: picture(), detail: String::new(), title: None, patient: String::new() });
        assert_eq!(cards.take_changes(), Changes::None);
    }

    #[test]
    fn a_folder_of_series_gets_a_card_per_series_and_gone_scans_lose_theirs() {
        let folder = tempfile::tempdir().unwrap();
        let study = folder.path().join("study");
        std::fs::create_dir(&study).unwrap();
        let mut cards = Cards::new(vec![VolumeSource::Demo, VolumeSource::Path(study.clone())]);
        let series =
            |uid: &str| VolumeSource::Series { folder: study.clone(), series_uid: uid.into(), label: uid.into() };
        cards.folder_of_series(1, 2);
        let added = cards.add_new(vec![series("1.2"), series("3.4")]);
        assert_eq!(added.iter().map(|(index, _)| *index).collect::<Vec<_>>(), [2, 3]);
        assert_eq!(cards.series_of(&VolumeSource::Path(study.clone())), 2);
        assert_eq!(cards.card(1).unwrap().detail, "2 series, a card each");
        cards.take_changes();
        assert_eq!(cards.drop_gone(), 0);
        assert_eq!(cards.take_changes(), Changes::None);
        std::fs::remove_dir(&study).unwrap();
        assert_eq!(cards.drop_gone(), 3, "the folder and its two series");
        assert_eq!(cards.sources(), [VolumeSource::Demo]);
        assert_eq!(cards.len(), 1);
        assert_eq!(cards.take_changes(), Changes::All);
    }

    #[test]
    fn a_received_series_card_says_when_it_is_deleted_and_another_scan_says_nothing() {
        let data = tempfile::tempdir().unwrap();
        let series = data.path().join("CT-0123456789abcdef");
        let copied = data.path().join("head.nrrd");
        std::fs::create_dir(&series).unwrap();
        std::fs::write(&copied, b"x").unwrap();
        let mut cards = Cards::new(vec![VolumeSource::Demo, VolumeSource::Path(series), VolumeSource::Path(copied)]);
        cards.take_changes();
        let now = SystemTime::now();
        cards.note_expiry(Some(Duration::from_secs(24 * 3600)), now);
        let said: Vec<&str> = (0..3).map(|i| cards.card(i).unwrap().expires.as_str()).collect();
        assert_eq!(said, ["", "Deleted in 23 h", ""], "24 h less the moments since the folder was made");
        assert_eq!(cards.take_changes(), Changes::Rows(vec![1]));
        cards.note_expiry(Some(Duration::from_secs(24 * 3600)), now);
        assert_eq!(cards.take_changes(), Changes::None, "an unchanged line is not pushed again");
        cards.note_expiry(Some(Duration::from_secs(3600)), now + Duration::from_secs(59 * 60 + 30));
        assert_eq!(cards.card(1).unwrap().expires, "Deleted at the next sweep");
        cards.note_expiry(None, now);
        assert_eq!(cards.card(1).unwrap().expires, "", "nothing expires without a retention period");
    }
}
