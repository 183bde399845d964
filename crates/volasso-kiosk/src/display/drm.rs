//! [`DrmDisplay`]: one connector of one DRM card, driven with two dumb buffers and page flips.
//!
//! Opening picks the card (the first `/dev/dri/cardN`, by N, with a connected connector, unless
//! one is named), the connector's mode ([`choose_mode`]: the preferred one), and a CRTC its
//! encoders can drive; it becomes DRM master and shows a black frame with `set_crtc`. Each
//! [`DrmDisplay::present`] lets the caller draw into the buffer not on screen and flips it in.
//! Dropping the display puts the CRTC back as it was (the text console, usually) and frees
//! the buffers.
//!
//! Never: polls for hot-plug, changes modes after opening, or uses atomic modesetting; a kiosk
//! has one fixed screen.

use std::fs::{File, OpenOptions};
use std::io;
use std::os::fd::{AsFd, BorrowedFd};
use std::path::{Path, PathBuf};

use ::drm::Device as BasicDevice;
use ::drm::buffer::{Buffer as _, DrmFourcc};
use ::drm::control::dumbbuffer::DumbBuffer;
use ::drm::control::{self, Device as ControlDevice, Event, Mode, ModeTypeFlags, PageFlipFlags, connector, crtc};

/// Where the kernel puts DRM cards.
const CARD_DIRECTORY: &str = "/dev/dri";

/// Errors opening or driving the display. The device path goes last in each message.
#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    #[error("no DRM card (cardN) in {directory}: is a display driver loaded (bochs-drm, virtio-gpu, i915, amdgpu)?")]
    NoCards { directory: PathBuf },
    #[error("permission denied opening {path}: the user must be in the `video` group")]
    PermissionDenied { path: PathBuf },
    #[error("cannot open {path}")]
    Open { path: PathBuf, source: io::Error },
    #[error("not a DRM device with modesetting (a render-only GPU?): {path}")]
    NotModesetting { path: PathBuf, source: io::Error },
    #[error("none of the {connectors} connectors is connected to a screen: {path}")]
    NoConnectedConnector { connectors: usize, path: PathBuf },
    #[error("connector {connector} reports no modes: {path}")]
    NoMode { connector: String, path: PathBuf },
    #[error("no CRTC can drive connector {connector}: {path}")]
    NoCrtc { connector: String, path: PathBuf },
    #[error("cannot set the display mode: another program (a desktop, another volasso) holds DRM master on {path}")]
    NotMaster { path: PathBuf, source: io::Error },
    #[error("dumb buffer of {width} pixels has a pitch of {pitch_bytes} bytes, not whole XRGB8888 pixels: {path}")]
    BufferLayout { width: u32, pitch_bytes: u32, path: PathBuf },
    #[error("DRM {operation} failed on {path}")]
    Drm { operation: &'static str, path: PathBuf, source: io::Error },
    #[error("no usable DRM card in {directory}: {}", list_failures(failures))]
    NoUsableCard { directory: PathBuf, failures: Vec<DisplayError> },
}

fn list_failures(failures: &[DisplayError]) -> String {
    failures.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")
}

/// The facts [`choose_mode`] weighs about one mode a connector offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeCandidate {
    pub width: u32,
    pub height: u32,
    pub refresh_hz: u32,
    /// The screen's EDID marks this as its native mode.
    pub preferred: bool,
}

impl From<&Mode> for ModeCandidate {
    fn from(mode: &Mode) -> Self {
        let (width, height) = mode.size();
        ModeCandidate {
            width: u32::from(width),
            height: u32::from(height),
            refresh_hz: mode.vrefresh(),
            preferred: mode.mode_type().contains(ModeTypeFlags::PREFERRED),
        }
    }
}

/// Index of the mode to use: the first preferred one (the panel's native resolution); without
/// one, the largest, then the fastest. `None` when there are no modes.
pub fn choose_mode(modes: &[ModeCandidate]) -> Option<usize> {
    if let Some(index) = modes.iter().position(|mode| mode.preferred) {
        return Some(index);
    }
    let key = |mode: &ModeCandidate| (u64::from(mode.width) * u64::from(mode.height), mode.refresh_hz);
    // max_by_key keeps the last of equals; reversing makes the first listed win ties.
    modes.iter().enumerate().rev().max_by_key(|(_, mode)| key(mode)).map(|(index, _)| index)
}

/// An open DRM card; drm-rs's device traits are implemented on it.
struct Card(File);

impl AsFd for Card {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.0.as_fd()
    }
}

impl BasicDevice for Card {}
impl ControlDevice for Card {}

/// One connected screen, shown through two dumb buffers that take turns on the CRTC.
pub struct DrmDisplay {
    card: Card,
    path: PathBuf,
    connector: connector::Handle,
    crtc: crtc::Handle,
    mode: Mode,
    /// The picture's size in millimetres as the connector reports it (EDID); may lie.
    physical_size_mm: Option<[u32; 2]>,
    /// What the CRTC showed before us (the console), restored on drop.
    saved_crtc: crtc::Info,
    buffers: [DumbBuffer; 2],
    framebuffers: [control::framebuffer::Handle; 2],
    /// Index into `buffers` of the one on screen (or queued to be).
    front: usize,
    /// A page flip was queued and its completion event not yet read.
    flip_pending: bool,
    /// The driver refused page flips once; every frame is then shown with `set_crtc`.
    flips_unsupported: bool,
}

impl DrmDisplay {
    /// Opens `card`, or without one the first card in `/dev/dri` with a connected screen, sets
    /// the connector's preferred mode and shows a black frame.
    pub fn open(card: Option<&Path>) -> Result<DrmDisplay, DisplayError> {
        match card {
            Some(path) => DrmDisplay::open_card(path),
            None => DrmDisplay::open_first_in(Path::new(CARD_DIRECTORY)),
        }
    }

    /// The mode's size in pixels, `[width, height]`.
    pub fn size(&self) -> [u32; 2] {
        let (width, height) = self.mode.size();
        [u32::from(width), u32::from(height)]
    }

    /// The picture's size in millimetres, `[width, height]`, as the connector reports it
    /// (EDID; 0 or an aspect ratio on some screens, so check it before trusting it).
    pub fn physical_size_mm(&self) -> Option<[u32; 2]> {
        self.physical_size_mm
    }

    /// Lets `draw` fill the back buffer (XRGB8888 rows of `stride` pixels, `stride >= width`)
    /// and shows it. Blocks until the previous frame's flip has completed (at most one refresh),
    /// so the buffer handed out is never on screen. It still holds what was drawn into it two
    /// presents ago (Slint's `RepaintBufferType::SwappedBuffers` redraws only what changed since).
    pub fn present(&mut self, draw: impl FnOnce(&mut [u32], usize)) -> Result<(), DisplayError> {
        self.wait_for_flip()?;
        let back = 1 - self.front;
        let [width, height] = self.size();
        let pitch_bytes = self.buffers[back].pitch();
        let stride = (pitch_bytes / 4) as usize;
        {
            let mut mapping = self.card.map_dumb_buffer(&mut self.buffers[back]).map_err(|source| {
                DisplayError::Drm { operation: "map dumb buffer", path: self.path.clone(), source }
            })?;
            let pixels: &mut [u32] = bytemuck::try_cast_slice_mut(mapping.as_mut())
                .map_err(|_| DisplayError::BufferLayout { width, pitch_bytes, path: self.path.clone() })?;
            let visible = (stride * height as usize).min(pixels.len());
            draw(&mut pixels[..visible], stride);
        }
        self.show(back)
    }

    fn show(&mut self, buffer: usize) -> Result<(), DisplayError> {
        if !self.flips_unsupported {
            match self.card.page_flip(self.crtc, self.framebuffers[buffer], PageFlipFlags::EVENT, None) {
                Ok(()) => {
                    self.front = buffer;
                    self.flip_pending = true;
                    return Ok(());
                }
                Err(error) if matches!(error.raw_os_error(), Some(libc_errno::EINVAL | libc_errno::ENOSYS)) => {
                    log::warn!("DRM page flip unsupported on {} ({error}); using set_crtc", self.path.display());
                    self.flips_unsupported = true;
                }
                Err(source) if matches!(source.raw_os_error(), Some(libc_errno::EACCES | libc_errno::EPERM)) => {
                    return Err(DisplayError::NotMaster { path: self.path.clone(), source });
                }
                Err(source) => {
                    return Err(DisplayError::Drm { operation: "page flip", path: self.path.clone(), source });
                }
            }
        }
        self.set_crtc(buffer)?;
        // Drivers with manual update (USB, SPI panels) need the dirty call; others answer ENOSYS.
        let _ = self.card.dirty_framebuffer(self.framebuffers[buffer], &[]);
        self.front = buffer;
        Ok(())
    }

    fn set_crtc(&self, buffer: usize) -> Result<(), DisplayError> {
        self.card
            .set_crtc(self.crtc, Some(self.framebuffers[buffer]), (0, 0), &[self.connector], Some(self.mode))
            .map_err(|source| match source.raw_os_error() {
                Some(libc_errno::EACCES | libc_errno::EPERM) => {
                    DisplayError::NotMaster { path: self.path.clone(), source }
                }
                _ => DisplayError::Drm { operation: "set CRTC", path: self.path.clone(), source },
            })
    }

    fn wait_for_flip(&mut self) -> Result<(), DisplayError> {
        while self.flip_pending {
            let events = self.card.receive_events().map_err(|source| DisplayError::Drm {
                operation: "read page flip event",
                path: self.path.clone(),
                source,
            })?;
            for event in events {
                if matches!(event, Event::PageFlip(flip) if flip.crtc == self.crtc) {
                    self.flip_pending = false;
                }
            }
        }
        Ok(())
    }

    fn open_first_in(directory: &Path) -> Result<DrmDisplay, DisplayError> {
        let mut cards = card_paths(directory);
        if cards.is_empty() {
            return Err(DisplayError::NoCards { directory: directory.to_path_buf() });
        }
        let mut failures = Vec::new();
        for path in cards.drain(..) {
            match DrmDisplay::open_card(&path) {
                Ok(display) => return Ok(display),
                Err(error) => failures.push(error),
            }
        }
        if failures.len() == 1 {
            return Err(failures.remove(0));
        }
        Err(DisplayError::NoUsableCard { directory: directory.to_path_buf(), failures })
    }

    fn open_card(path: &Path) -> Result<DrmDisplay, DisplayError> {
        let file = OpenOptions::new().read(true).write(true).open(path).map_err(|source| open_error(path, source))?;
        let card = Card(file);
        let drm_error = |operation: &'static str| {
            move |source: io::Error| DisplayError::Drm { operation, path: path.into(), source }
        };
        // The first opener is master already; a later one (root) may still take it. A failure
        // here shows up as NotMaster at the first set_crtc, with the facts.
        let _ = card.acquire_master_lock();
        let resources = card
            .resource_handles()
            .map_err(|source| DisplayError::NotModesetting { path: path.to_path_buf(), source })?;
        let mut connected = None;
        for &handle in resources.connectors() {
            let info = card.get_connector(handle, true).map_err(drm_error("get connector"))?;
            if info.state() == connector::State::Connected {
                connected = Some(info);
                break;
            }
        }
        let connector = connected.ok_or_else(|| DisplayError::NoConnectedConnector {
            connectors: resources.connectors().len(),
            path: path.to_path_buf(),
        })?;
        let connector_name = format!("{}-{}", connector.interface().as_str(), connector.interface_id());
        let candidates: Vec<ModeCandidate> = connector.modes().iter().map(ModeCandidate::from).collect();
        let mode = choose_mode(&candidates)
            .map(|index| connector.modes()[index])
            .ok_or_else(|| DisplayError::NoMode { connector: connector_name.clone(), path: path.to_path_buf() })?;
        let crtc = find_crtc(&card, &resources, &connector)
            .ok_or_else(|| DisplayError::NoCrtc { connector: connector_name.clone(), path: path.to_path_buf() })?;
        let saved_crtc = card.get_crtc(crtc).map_err(drm_error("get CRTC"))?;

        let (width, height) = mode.size();
        let size = (u32::from(width), u32::from(height));
        let (first, first_framebuffer) = create_buffer(&card, size, path)?;
        let (second, second_framebuffer) = create_buffer(&card, size, path)?;
        let display = DrmDisplay {
            card,
            path: path.to_path_buf(),
            connector: connector.handle(),
            crtc,
            mode,
            physical_size_mm: connector.size().map(|(width, height)| [width, height]),
            saved_crtc,
            buffers: [first, second],
            framebuffers: [first_framebuffer, second_framebuffer],
            front: 0,
            flip_pending: false,
            flips_unsupported: false,
        };
        display.set_crtc(0)?;
        log::info!("display {} {connector_name} {}x{}@{} Hz", path.display(), width, height, mode.vrefresh());
        Ok(display)
    }
}

impl Drop for DrmDisplay {
    fn drop(&mut self) {
        // A queued flip still references our framebuffer; let it land before freeing it.
        if self.wait_for_flip().is_err() {
            self.flip_pending = false;
        }
        let restored = match (self.saved_crtc.framebuffer(), self.saved_crtc.mode()) {
            (Some(framebuffer), Some(mode)) => self.card.set_crtc(
                self.crtc,
                Some(framebuffer),
                self.saved_crtc.position(),
                &[self.connector],
                Some(mode),
            ),
            _ => self.card.set_crtc(self.crtc, None, (0, 0), &[], None),
        };
        if let Err(error) = restored {
            log::warn!("cannot restore the display on {}: {error}", self.path.display());
        }
        for framebuffer in self.framebuffers {
            let _ = self.card.destroy_framebuffer(framebuffer);
        }
        for buffer in self.buffers {
            let _ = self.card.destroy_dumb_buffer(buffer);
        }
        let _ = self.card.release_master_lock();
    }
}

/// One black XRGB8888 dumb buffer of `size` pixels and the framebuffer that shows it. On error
/// the buffers made so far are freed when the card closes.
fn create_buffer(
    card: &Card,
    size: (u32, u32),
    path: &Path,
) -> Result<(DumbBuffer, control::framebuffer::Handle), DisplayError> {
    let drm_error =
        |operation: &'static str| move |source: io::Error| DisplayError::Drm { operation, path: path.into(), source };
    let mut buffer = card.create_dumb_buffer(size, DrmFourcc::Xrgb8888, 32).map_err(drm_error("create dumb buffer"))?;
    if buffer.pitch() % 4 != 0 {
        return Err(DisplayError::BufferLayout {
            width: size.0,
            pitch_bytes: buffer.pitch(),
            path: path.to_path_buf(),
        });
    }
    card.map_dumb_buffer(&mut buffer).map_err(drm_error("map dumb buffer"))?.as_mut().fill(0);
    let framebuffer = card.add_framebuffer(&buffer, 24, 32).map_err(drm_error("add framebuffer"))?;
    Ok((buffer, framebuffer))
}

/// `cardN` entries of `directory`, ordered by N (card10 after card2); render nodes excluded.
fn card_paths(directory: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(directory) else {
        return Vec::new();
    };
    let mut cards: Vec<(u32, PathBuf)> = entries
        .filter_map(Result::ok)
        .filter_map(|entry| {
            let name = entry.file_name();
            let number = name.to_str()?.strip_prefix("card")?.parse::<u32>().ok()?;
            Some((number, entry.path()))
        })
        .collect();
    cards.sort();
    cards.into_iter().map(|(_, path)| path).collect()
}

fn open_error(path: &Path, source: io::Error) -> DisplayError {
    if source.kind() == io::ErrorKind::PermissionDenied {
        DisplayError::PermissionDenied { path: path.to_path_buf() }
    } else {
        DisplayError::Open { path: path.to_path_buf(), source }
    }
}

/// Linux errno values the display tells apart (no libc crate for four constants).
mod libc_errno {
    pub const EPERM: i32 = 1;
    pub const EACCES: i32 = 13;
    pub const EINVAL: i32 = 22;
    pub const ENOSYS: i32 = 38;
}

/// The CRTC that already drives the connector (the console's), else the first its encoders allow.
fn find_crtc(card: &Card, resources: &control::ResourceHandles, connector: &connector::Info) -> Option<crtc::Handle> {
    let current = connector.current_encoder().and_then(|encoder| card.get_encoder(encoder).ok());
    if let Some(crtc) = current.and_then(|encoder| encoder.crtc()) {
        return Some(crtc);
    }
    connector
        .encoders()
        .iter()
        .filter_map(|&encoder| card.get_encoder(encoder).ok())
        .find_map(|encoder| resources.filter_crtcs(encoder.possible_crtcs()).first().copied())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(width: u32, height: u32, refresh_hz: u32, preferred: bool) -> ModeCandidate {
        ModeCandidate { width, height, refresh_hz, preferred }
    }

    #[test]
    fn the_preferred_mode_wins_over_larger_ones() {
        let modes = [mode(1920, 1080, 60, false), mode(1280, 800, 60, true), mode(1280, 800, 75, true)];
        assert_eq!(choose_mode(&modes), Some(1));
    }

    #[test]
    fn without_a_preferred_mode_the_largest_then_fastest_wins() {
        let modes = [mode(1024, 768, 75, false), mode(1920, 1080, 50, false), mode(1920, 1080, 60, false)];
        assert_eq!(choose_mode(&modes), Some(2));
        let ties = [mode(800, 600, 60, false), mode(800, 600, 60, false)];
        assert_eq!(choose_mode(&ties), Some(0), "the first listed of equal modes");
    }

    #[test]
    fn no_modes_chooses_nothing() {
        assert_eq!(choose_mode(&[]), None);
    }

    #[test]
    fn cards_are_ordered_by_number_and_render_nodes_ignored() {
        let directory = tempfile::tempdir().unwrap();
        for name in ["card10", "card2", "renderD128", "card0", "cardx", "by-path"] {
            std::fs::write(directory.path().join(name), b"").unwrap();
        }
        let names: Vec<String> = card_paths(directory.path())
            .iter()
            .map(|path| path.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["card0", "card2", "card10"]);
    }

    #[test]
    fn an_empty_or_missing_card_directory_says_no_cards() {
        let directory = tempfile::tempdir().unwrap();
        let error = DrmDisplay::open_first_in(directory.path()).err().unwrap();
        assert!(matches!(error, DisplayError::NoCards { .. }), "{error}");
        let missing = directory.path().join("dri");
        let error = DrmDisplay::open_first_in(&missing).err().unwrap();
        assert!(matches!(&error, DisplayError::NoCards { directory } if *directory == missing), "{error}");
    }

    #[test]
    fn a_file_that_is_no_drm_device_is_named_in_the_error() {
        let directory = tempfile::tempdir().unwrap();
        let path = directory.path().join("card0");
        std::fs::write(&path, b"not a device").unwrap();
        let error = DrmDisplay::open(Some(&path)).err().unwrap();
        assert!(matches!(&error, DisplayError::NotModesetting { path: named, .. } if *named == path), "{error}");
        assert!(error.to_string().ends_with(&path.display().to_string()), "path goes last: {error}");
    }

    #[test]
    fn every_unusable_card_is_reported() {
        let directory = tempfile::tempdir().unwrap();
        for name in ["card0", "card1"] {
            std::fs::write(directory.path().join(name), b"").unwrap();
        }
        let error = DrmDisplay::open_first_in(directory.path()).err().unwrap();
        let DisplayError::NoUsableCard { failures, .. } = &error else { panic!("{error}") };
        assert_eq!(failures.len(), 2);
        assert!(error.to_string().contains("card0") && error.to_string().contains("card1"), "{error}");
    }

    #[test]
    fn a_missing_card_and_a_denied_card_are_told_apart() {
        let missing = Path::new("/nonexistent/dri/card0");
        let error = DrmDisplay::open(Some(missing)).err().unwrap();
        assert!(matches!(error, DisplayError::Open { .. }), "{error}");
        // Root (as tests run here) is never denied, so the mapping is checked directly.
        let denied = open_error(missing, io::Error::from(io::ErrorKind::PermissionDenied));
        assert!(matches!(denied, DisplayError::PermissionDenied { .. }));
        assert!(denied.to_string().contains("`video` group"), "{denied}");
    }
}
