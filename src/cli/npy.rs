//! A minimal NumPy `.npy` writer (format version 1.0) for exporting feature blocks to scripts.

use std::io::Write;
use std::path::Path;

/// Element types the writer knows, with their NumPy descriptors.
pub trait NpyElement: Copy {
    const DESCRIPTOR: &'static str;
    fn write_le(self, out: &mut Vec<u8>);
}

impl NpyElement for f32 {
    const DESCRIPTOR: &'static str = "<f4";
    fn write_le(self, out: &mut Vec<u8>) {
        out.extend(self.to_le_bytes());
    }
}

impl NpyElement for u8 {
    const DESCRIPTOR: &'static str = "|u1";
    fn write_le(self, out: &mut Vec<u8>) {
        out.push(self);
    }
}

/// Writes `values` as an array of `shape` (C order) to `path`, atomically.
pub fn write<T: NpyElement>(path: &Path, shape: &[usize], values: &[T]) -> std::io::Result<()> {
    let shape_text = match shape {
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")),
    };
    let mut header = format!("{{'descr': '{}', 'fortran_order': False, 'shape': {shape_text}, }}", T::DESCRIPTOR);
    // Magic (6) + version (2) + length (2) + header + newline, padded to a multiple of 64.
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + std::mem::size_of_val(values));
    bytes.extend_from_slice(b"\x93NUMPY\x01\x00");
    bytes.extend((header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for &value in values {
        value.write_le(&mut bytes);
    }
    crate::atomic_file::write_atomically(path, |file| file.write_all(&bytes))
}
