//! The image size a compressed frame's own header declares, checked against Rows, Columns and
//! SamplesPerPixel before a decoder sees the frame: the decoders (jpeg-decoder, CharLS,
//! OpenJPEG) allocate what their codestream header says, so a 2 KB fragment claiming
//! 65535 x 65535 pixels would ask for gigabytes, and an allocation that fails aborts the process.
//!
//! Read here: JPEG and JPEG-LS frame headers (SOFn, SOF55: ITU T.81 B.2.2, T.87 C.2.2) and the
//! JPEG 2000 SIZ marker (T.800 A.5.1). Other syntaxes (RLE: sized by the DICOM header) pass.
//!
//! Never: decodes, or accepts a codestream whose size differs from the DICOM header's.

/// Width, height and components as a codestream header declares them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct DeclaredSize {
    pub width: u32,
    pub height: u32,
    pub components: u32,
    /// Bits per sample of a JPEG frame header (8 or 12 for DCT, 2..16 lossless); `None` for
    /// JPEG 2000.
    pub precision: Option<u8>,
}

/// The size `frame` (the start of one frame's compressed bytes) declares for transfer syntax
/// `uid`; `None` when the syntax has no such header or none is found in the first bytes (the
/// decoder then fails on its own, allocating nothing from a header).
pub(super) fn declared_size(uid: &str, frame: &[u8]) -> Option<DeclaredSize> {
    match uid {
        "1.2.840.10008.1.2.4.50"
        | "1.2.840.10008.1.2.4.51"
        | "1.2.840.10008.1.2.4.57"
        | "1.2.840.10008.1.2.4.70"
        | "1.2.840.10008.1.2.4.80"
        | "1.2.840.10008.1.2.4.81" => jpeg_frame_header(frame),
        "1.2.840.10008.1.2.4.90" | "1.2.840.10008.1.2.4.91" => jpeg2000_siz(frame),
        _ => None,
    }
}

/// The first SOFn (or JPEG-LS SOF55) segment after SOI, skipping the segments before it.
fn jpeg_frame_header(bytes: &[u8]) -> Option<DeclaredSize> {
    if bytes.get(..2)? != [0xFF, 0xD8] {
        return None;
    }
    let mut position = 2;
    loop {
        // Fill bytes (0xFF) may precede a marker.
        while *bytes.get(position)? == 0xFF && *bytes.get(position + 1)? == 0xFF {
            position += 1;
        }
        if *bytes.get(position)? != 0xFF {
            return None;
        }
        let marker = *bytes.get(position + 1)?;
        let length = usize::from(u16::from_be_bytes([*bytes.get(position + 2)?, *bytes.get(position + 3)?]));
        let is_frame_header = matches!(marker, 0xC0..=0xC3 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF | 0xF7);
        if is_frame_header {
            let segment = bytes.get(position + 4..position + 2 + length)?;
            return Some(DeclaredSize {
                height: u32::from(u16::from_be_bytes([*segment.get(1)?, *segment.get(2)?])),
                width: u32::from(u16::from_be_bytes([*segment.get(3)?, *segment.get(4)?])),
                components: u32::from(*segment.get(5)?),
                precision: Some(*segment.first()?),
            });
        }
        if marker == 0xDA || length < 2 {
            // Start of scan before any frame header, or a broken length.
            return None;
        }
        position += 2 + length;
    }
}

/// The SIZ marker segment that follows SOC in a JPEG 2000 codestream (also found inside a JP2
/// file's contiguous codestream box, within the first kilobytes).
fn jpeg2000_siz(bytes: &[u8]) -> Option<DeclaredSize> {
    let window = &bytes[..bytes.len().min(64 << 10)];
    let start = window.windows(4).position(|w| w == [0xFF, 0x4F, 0xFF, 0x51])? + 4;
    let siz = bytes.get(start..start + 38)?;
    let word = |at: usize| u32::from_be_bytes([siz[at], siz[at + 1], siz[at + 2], siz[at + 3]]);
    // Lsiz(2) Rsiz(2) Xsiz Ysiz XOsiz YOsiz XTsiz YTsiz XTOsiz YTOsiz (4 each) Csiz(2).
    Some(DeclaredSize {
        width: word(4).checked_sub(word(12))?,
        height: word(8).checked_sub(word(16))?,
        components: u32::from(u16::from_be_bytes([siz[36], siz[37]])),
        precision: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SOI, an APP0 segment, then SOF3 (lossless) of `height` x `width`, one component.
    fn jpeg(height: u16, width: u16) -> Vec<u8> {
        let mut bytes = vec![0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x04, 0xAB, 0xCD, 0xFF, 0xC3, 0x00, 0x0B, 16];
        bytes.extend(height.to_be_bytes());
        bytes.extend(width.to_be_bytes());
        bytes.extend([1, 1, 0x11, 0]);
        bytes
    }

    #[test]
    fn jpeg_and_jpeg_ls_headers_are_read_past_other_segments() {
        let size = declared_size("1.2.840.10008.1.2.4.70", &jpeg(512, 256)).unwrap();
        assert_eq!(size, DeclaredSize { width: 256, height: 512, components: 1, precision: Some(16) });
        let mut ls = jpeg(65535, 65535);
        ls[9] = 0xF7;
        assert_eq!(declared_size("1.2.840.10008.1.2.4.80", &ls).unwrap().width, 65535);
        assert_eq!(declared_size("1.2.840.10008.1.2.4.70", &jpeg(512, 512)[..12]), None);
        assert_eq!(declared_size("1.2.840.10008.1.2.5", &jpeg(512, 512)), None);
    }

    #[test]
    fn a_jpeg_2000_siz_gives_the_image_area() {
        let mut bytes = vec![0xFF, 0x4F, 0xFF, 0x51, 0x00, 0x29, 0x00, 0x00];
        for value in [1000u32, 800, 100, 50, 1000, 800, 0, 0] {
            bytes.extend(value.to_be_bytes());
        }
        bytes.extend(1u16.to_be_bytes());
        let size = declared_size("1.2.840.10008.1.2.4.90", &bytes).unwrap();
        assert_eq!(size, DeclaredSize { width: 900, height: 750, components: 1, precision: None });
    }
}
