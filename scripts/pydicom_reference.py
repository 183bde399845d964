#!/usr/bin/env python3
"""Writes DICOM files that once tripped volasso's reader, each with the voxels pydicom decodes
from it, for `tests/dicom_codecs.rs` to compare with what volasso reads.

Usage: python3 scripts/pydicom_reference.py OUT_DIR

For each case NAME it writes OUT_DIR/NAME.dcm, OUT_DIR/NAME.pydicom.f64 (pydicom's voxels:
`pixel_array` then `apply_modality_lut`, frames x rows x columns, little-endian float64) and,
for 12-bit lossy JPEG, OUT_DIR/NAME.dcmtk.f64 (the voxels of dcmtk's `dcmdjpeg` output, read by
pydicom); OUT_DIR/cases.json lists every case with its shape and how it was made. A file
pydicom's wheel ships is copied from it; one it would download (which a machine without the
internet cannot) is made here with pydicom and dcmtk to carry the same trait, from files the
wheel ships. Nothing is read from outside pydicom's wheel and nothing is downloaded.

Needs pydicom 3 with pylibjpeg, pylibjpeg-libjpeg, pylibjpeg-openjpeg and pyjpegls (decoding
and encoding JPEG 2000 and JPEG-LS, decoding 12-bit JPEG), numpy, and dcmtk (dcmconv,
dcmcjpeg, dcmdjpeg); `.ci/run` installs them.

Never: writes outside OUT_DIR.
"""

import copy
import json
import os
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pydicom
from pydicom.dataset import FileMetaDataset
from pydicom.filebase import DicomBytesIO
from pydicom.filewriter import write_data_element
from pydicom.pixels import apply_modality_lut
from pydicom.uid import (
    JPEG2000Lossless,
    JPEGLSLossless,
    RLELossless,
    ExplicitVRLittleEndian,
    ImplicitVRLittleEndian,
    generate_uid,
)

WHEEL = os.path.join(os.path.dirname(pydicom.__file__), "data", "test_files")
ENHANCED_MR = "1.2.840.10008.5.1.4.1.1.4.1"


def wheel_file(name):
    path = os.path.join(WHEEL, name)
    if not os.path.isfile(path):
        sys.exit(f"pydicom {pydicom.__version__}'s wheel lacks {name}")
    return path


def values(path):
    """pydicom's voxels of `path` as (frames, rows, columns) float64."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = pydicom.dcmread(path)
        decoded = apply_modality_lut(ds.pixel_array, ds).astype(np.float64)
    return decoded if int(ds.get("NumberOfFrames", 1) or 1) > 1 else decoded[np.newaxis]


def run(*command):
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"{' '.join(command)} failed: {result.stderr.strip()}")


def save(ds, path, syntax):
    ds.file_meta.TransferSyntaxUID = syntax
    ds.save_as(path, enforce_file_format=True, implicit_vr=syntax == ImplicitVRLittleEndian, little_endian=True)


def new_image(sop_class, rows, columns, stored, *, signed, bits_stored, frames=None):
    """A minimal greyscale image data set holding `stored` (a numpy array) as 16-bit samples."""
    ds = pydicom.Dataset()
    ds.file_meta = FileMetaDataset()
    ds.file_meta.MediaStorageSOPClassUID = sop_class
    ds.file_meta.MediaStorageSOPInstanceUID = generate_uid()
    ds.SOPClassUID = sop_class
    ds.SOPInstanceUID = ds.file_meta.MediaStorageSOPInstanceUID
    ds.SeriesInstanceUID = generate_uid()
    ds.StudyInstanceUID = generate_uid()
    ds.Modality = "OT"
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.Rows, ds.Columns = rows, columns
    if frames is not None:
        ds.NumberOfFrames = frames
    ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, bits_stored, bits_stored - 1
    ds.PixelRepresentation = 1 if signed else 0
    ds.PixelData = stored.astype("<i2" if signed else "<u2").tobytes()
    return ds


def modality_lut(ds, descriptor, data, data_vr):
    item = pydicom.Dataset()
    item.add_new("LUTDescriptor", "SS" if descriptor[1] < 0 else "US", descriptor)
    item.ModalityLUTType = "US"
    if data_vr == "OW":
        item.add_new("LUTData", "OW", np.asarray(data, dtype="<u2").tobytes())
    else:
        item.add_new("LUTData", "US", [int(v) for v in data])
    ds.ModalityLUTSequence = [item]


def make_mlut(out):
    """mlut_18.dcm's trait: signed 12-bit samples mapped by a 4096-entry, 16-bit LUT whose
    first mapped value is -2048 (LUTDescriptor SS), in explicit VR; and two more: unsigned
    samples beyond both ends of a short OW table in implicit VR, and signed samples through an
    8-bit table whose negative first value an implicit reading sees as unsigned."""
    table = (np.arange(4096, dtype=np.int64) ** 2 * 65535 // 4095**2).astype(np.uint16)
    stored = np.arange(-2048, 2048).reshape(64, 64)
    ds = new_image("1.2.840.10008.5.1.4.1.1.7", 64, 64, stored, signed=True, bits_stored=12)
    modality_lut(ds, [4096, -2048, 16], table, "US")
    save(ds, os.path.join(out, "mlut_18.dcm"), ExplicitVRLittleEndian)

    stored = np.arange(0, 4096).reshape(64, 64)
    ds = new_image("1.2.840.10008.5.1.4.1.1.7", 64, 64, stored, signed=False, bits_stored=16)
    modality_lut(ds, [1000, 1500, 16], np.arange(1000) * 37 + 11, "OW")
    save(ds, os.path.join(out, "mlut_clipped_implicit.dcm"), ImplicitVRLittleEndian)

    stored = np.arange(-300, 212).reshape(16, 32)
    ds = new_image("1.2.840.10008.5.1.4.1.1.7", 16, 32, stored, signed=True, bits_stored=16)
    modality_lut(ds, [256, -100, 8], (np.arange(256) * 7) % 256, "OW")
    save(ds, os.path.join(out, "mlut_8bit_signed_implicit.dcm"), ImplicitVRLittleEndian)
    return [
        ("mlut_18", "made: signed 12-bit samples, LUTDescriptor [4096, -2048, 16] (SS), 16-bit US LUTData"),
        ("mlut_clipped_implicit", "made: unsigned samples 0..4095 through LUTDescriptor [1000, 1500, 16], OW data, implicit VR"),
        ("mlut_8bit_signed_implicit", "made: signed samples through LUTDescriptor [256, -100, 8], implicit VR"),
    ]


def as_un(element):
    """`element` re-encoded with VR UN: its value bytes as implicit VR little endian has them."""
    buffer = DicomBytesIO()
    buffer.is_little_endian, buffer.is_implicit_VR = True, True
    write_data_element(buffer, element)
    return pydicom.DataElement(element.tag, "UN", buffer.getvalue()[8:])


def make_explicit_vr_un(out):
    """explicit_VR-UN.dcm's trait: every attribute but the Image Pixel module's US ones (and the
    character set) stored as UN: RescaleSlope, RescaleIntercept, PixelSpacing, positions, UIDs;
    here with slope 2, so that a reader ignoring it is caught."""
    ds = pydicom.dcmread(wheel_file("CT_small.dcm"))
    ds.RescaleSlope = 2
    # pydicom gives a UN element its dictionary VR as it is set, unless told not to; it does so
    # again when the file is read back for the reference values, as by default.
    pydicom.config.replace_un_with_known_vr = False
    try:
        for element in list(ds):
            image_pixel = element.tag.group == 0x0028 and element.VR != "DS"
            # SpecificCharacterSet stays CS: pydicom cannot write a data set whose one is UN.
            kept = element.tag in (0x00080005, 0x7FE00010) or image_pixel
            if element.VR not in ("SQ", "OB", "OW", "UN") and not kept:
                ds[element.tag] = as_un(element)
        ds.save_as(os.path.join(out, "explicit_VR-UN.dcm"), enforce_file_format=True)
    finally:
        pydicom.config.replace_un_with_known_vr = True
    return [("explicit_VR-UN", "made from CT_small.dcm: every attribute but US ones as UN, RescaleSlope 2")]


def make_emri(out):
    """emri_small*.dcm's trait: an Enhanced MR file of 10 frames without functional groups
    (no positions, no pixel spacing; SpacingBetweenSlices 1.2), 12-bit unsigned, in the five
    syntaxes pydicom's set has it in."""
    mr = pydicom.dcmread(wheel_file("MR_small.dcm")).pixel_array.astype(np.int64)
    frames = np.stack([np.clip(mr + 97 * k, 0, 4095) for k in range(10)])
    ds = new_image(ENHANCED_MR, 64, 64, frames, signed=False, bits_stored=12, frames=10)
    ds.Modality = "MR"
    ds.SpacingBetweenSlices = "1.2"
    plain = os.path.join(out, "emri_small.dcm")
    save(ds, plain, ExplicitVRLittleEndian)
    for name, syntax in [("emri_small_RLE", RLELossless), ("emri_small_jpeg_2k_lossless", JPEG2000Lossless),
                         ("emri_small_jpeg_ls_lossless", JPEGLSLossless)]:
        compressed = copy.deepcopy(ds)
        compressed.compress(syntax, generate_instance_uid=False)
        compressed.save_as(os.path.join(out, name + ".dcm"), enforce_file_format=True)
    run("dcmconv", "+tb", plain, os.path.join(out, "emri_small_big_endian.dcm"))
    return [(name, f"made: Enhanced MR, 10 frames, no functional groups, {how}") for name, how in [
        ("emri_small", "explicit VR little endian"),
        ("emri_small_RLE", "RLE Lossless (pydicom)"),
        ("emri_small_big_endian", "explicit VR big endian (dcmtk dcmconv +tb)"),
        ("emri_small_jpeg_2k_lossless", "JPEG 2000 lossless (pydicom, OpenJPEG)"),
        ("emri_small_jpeg_ls_lossless", "JPEG-LS lossless (pydicom, CharLS)"),
    ]]


def make_jpeg12(out):
    """12-bit lossy JPEG (process 4): pydicom's JPGExtended.dcm and JPEG-lossy.dcm (the same
    codestream with the scan's spectral selection end 0 instead of 63, which pydicom refuses and
    sequential decoders ignore: its reference is JPGExtended's), and a 12-bit MR compressed by
    dcmtk's `dcmcjpeg +ee`."""
    shutil.copy(wheel_file("JPGExtended.dcm"), os.path.join(out, "JPGExtended.dcm"))
    shutil.copy(wheel_file("JPEG-lossy.dcm"), os.path.join(out, "JPEG-lossy.dcm"))
    mr = pydicom.dcmread(wheel_file("MR_small.dcm"))
    ds = new_image(mr.SOPClassUID, 64, 64, np.clip(mr.pixel_array.astype(np.int64) * 2, 0, 4095), signed=False,
                   bits_stored=12)
    ds.Modality = "MR"
    twelve = os.path.join(out, "mr_12bit.uncompressed")
    save(ds, twelve, ExplicitVRLittleEndian)
    run("dcmcjpeg", "+ee", twelve, os.path.join(out, "dcmcjpeg_ee.dcm"))
    os.remove(twelve)
    for name in ("JPGExtended", "JPEG-lossy", "dcmcjpeg_ee"):
        decompressed = os.path.join(out, name + ".dcmdjpeg")
        run("dcmdjpeg", os.path.join(out, name + ".dcm"), decompressed)
        values(decompressed).astype("<f8").tofile(os.path.join(out, name + ".dcmtk.f64"))
        os.remove(decompressed)
    return [
        ("JPGExtended", "pydicom's wheel: NEMA's NM1_JPLY with a fixed scan header"),
        ("JPEG-lossy", "pydicom's wheel: NM1_JPLY; pydicom cannot decode it, its reference is JPGExtended's"),
        ("dcmcjpeg_ee", "made: MR_small.dcm's values doubled as 12-bit unsigned, dcmtk dcmcjpeg +ee"),
    ]


def make_others(out):
    shutil.copy(wheel_file("MR_small_padded.dcm"), os.path.join(out, "MR_small_padded.dcm"))
    ds = pydicom.dcmread(wheel_file(os.path.join("dicomdirtests", "77654033", "CR1", "6154")))
    del ds.ImagerPixelSpacing
    ds.PixelSpacing = [0, 0]
    ds.save_as(os.path.join(out, "CR_pixel_spacing_0.dcm"), enforce_file_format=True)
    return [
        ("MR_small_padded", "pydicom's wheel: MR_small.dcm with 128 zero bytes after its PixelData"),
        ("CR_pixel_spacing_0", "made from the wheel's CR dicomdirtests/77654033/CR1/6154: PixelSpacing 0 \\ 0, as RG1_J2KI.dcm"),
    ]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__.split("\n\n")[1])
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    # pydicom warns about what these files are made to carry (values as UN, padding).
    warnings.simplefilter("ignore")
    cases = make_mlut(out) + make_explicit_vr_un(out) + make_emri(out) + make_jpeg12(out) + make_others(out)
    listed = []
    for name, how in cases:
        # JPEG-lossy.dcm differs from JPGExtended.dcm only in a byte sequential decoding ignores.
        source = "JPGExtended" if name == "JPEG-lossy" else name
        decoded = values(os.path.join(out, source + ".dcm"))
        decoded.astype("<f8").tofile(os.path.join(out, name + ".pydicom.f64"))
        listed.append({"name": name, "shape": list(decoded.shape), "made": how})
    with open(os.path.join(out, "cases.json"), "w") as file:
        json.dump({"pydicom": pydicom.__version__, "cases": listed}, file, indent=1)
    print(f"pydicom {pydicom.__version__}: {len(listed)} cases in {out}")


if __name__ == "__main__":
    main()
