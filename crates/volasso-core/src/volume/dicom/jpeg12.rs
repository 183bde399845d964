//! 12-bit lossy JPEG frames (JPEG Extended, process 4: 12-bit DCT with Huffman coding), which
//! dicom-rs's JPEG decoder (jpeg-decoder, 8-bit DCT only) refuses: decoded by libjpeg-turbo's
//! 12-bit API (`tj3Decompress12`, through turbojpeg-sys), the IJG code that dcmtk's own 12-bit
//! decoder also derives from. Other lossy JPEG decoders (pydicom's pylibjpeg) may differ from it
//! by 1 in a few samples: the standard allows that much IDCT error (ISO 10918-2).
//!
//! [`decode`] takes one frame's whole codestream, whose size the caller has already checked
//! against Rows and Columns ([`super::codestream`]), and returns its samples row by row.
//!
//! Never: decodes colour or more than one component, returns an image a warning says is
//! damaged (corrupt data, a premature end: libjpeg fills the rest with grey), or lets a
//! libjpeg-turbo handle outlive the call.

use std::ffi::CStr;
use turbojpeg_sys as tj;

/// The one libjpeg warning that does not mean damaged pixels: a sequential scan whose
/// spectral selection is not 0..63, which sequential decoding ignores (NEMA's NM1_JPLY, pydicom's
/// `JPEG-lossy.dcm`, has Se = 0).
const HARMLESS_WARNING: &str = "Invalid SOS parameters for sequential JPEG";

/// One 12-bit greyscale frame: `width * height` samples (0..4095), row by row, and the
/// decoder's harmless warning when it gave one.
#[derive(Debug)]
pub(super) struct Decoded {
    pub samples: Vec<u16>,
    pub warning: Option<String>,
}

/// A decompression handle, destroyed when dropped.
struct Handle(tj::tjhandle);

impl Drop for Handle {
    fn drop(&mut self) {
        // SAFETY: the handle came from tj3Init and is destroyed once, here.
        unsafe { tj::tj3Destroy(self.0) };
    }
}

impl Handle {
    fn error(&self) -> String {
        // SAFETY: tj3GetErrorStr returns a NUL-terminated string owned by the handle, valid
        // until the next call on it; it is copied at once.
        unsafe { CStr::from_ptr(tj::tj3GetErrorStr(self.0)).to_string_lossy().into_owned() }
    }

    fn get(&self, parameter: tj::TJPARAM) -> i32 {
        // SAFETY: a valid handle and a parameter constant of libjpeg-turbo's own header.
        unsafe { tj::tj3Get(self.0, parameter as i32) }
    }
}

/// Decodes `codestream`, which must be a 12-bit, one-component JPEG of `width` x `height`.
pub(super) fn decode(codestream: &[u8], width: usize, height: usize) -> Result<Decoded, String> {
    // SAFETY: tj3Init has no preconditions; a null result is checked.
    let handle = Handle(unsafe { tj::tj3Init(tj::TJINIT_TJINIT_DECOMPRESS as i32) });
    if handle.0.is_null() {
        return Err("libjpeg-turbo could not start a decompressor".into());
    }
    // SAFETY: the pointer and length describe `codestream`, which outlives the call.
    if unsafe { tj::tj3DecompressHeader(handle.0, codestream.as_ptr(), codestream.len() as tj::size_t) } != 0 {
        return Err(handle.error());
    }
    let (declared_width, declared_height) =
        (handle.get(tj::TJPARAM_TJPARAM_JPEGWIDTH), handle.get(tj::TJPARAM_TJPARAM_JPEGHEIGHT));
    let precision = handle.get(tj::TJPARAM_TJPARAM_PRECISION);
    let colour_space = handle.get(tj::TJPARAM_TJPARAM_COLORSPACE);
    if (declared_width, declared_height) != (width as i32, height as i32) {
        return Err(format!("the codestream is {declared_width} x {declared_height}, not {width} x {height}"));
    }
    if precision != 12 || colour_space != tj::TJCS_TJCS_GRAY as i32 {
        return Err(format!("the codestream is {precision}-bit with colour space {colour_space}, not 12-bit grey"));
    }
    let mut samples = vec![0i16; width * height];
    // SAFETY: `samples` holds width x height 16-bit samples, exactly what one-component output
    // of the size checked above writes with pitch 0 (rows packed); the codestream outlives the call.
    let status = unsafe {
        tj::tj3Decompress12(
            handle.0,
            codestream.as_ptr(),
            codestream.len() as tj::size_t,
            samples.as_mut_ptr(),
            0,
            tj::TJPF_TJPF_GRAY,
        )
    };
    let warning = if status == 0 {
        None
    } else {
        let message = handle.error();
        // SAFETY: a valid handle.
        let severity = unsafe { tj::tj3GetErrorCode(handle.0) };
        if severity != tj::TJERR_TJERR_WARNING as i32 || !message.contains(HARMLESS_WARNING) {
            return Err(message);
        }
        Some(message)
    };
    // 12-bit samples are 0..4095: the cast keeps them.
    Ok(Decoded { samples: samples.into_iter().map(|sample| sample as u16).collect(), warning })
}
