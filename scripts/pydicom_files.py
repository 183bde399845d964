#!/usr/bin/env python3
"""Runs `volasso import` over every file of pydicom's bundled test data and compares each
volume it reads with pydicom's decoding, voxel for voxel: `pixel_array`, then
`apply_modality_lut` (as a viewer shows it), or for an enhanced multi-frame file each frame's
rescale from its functional groups (which `apply_modality_lut` does not read); rounded to
float32, volasso's type for values that are not all integers in int16's range.

Usage:
    python3 scripts/pydicom_files.py VOLASSO [--extra DIR]... [--json OUT.json] [--compare OLD.json]

VOLASSO is the volasso binary. The files are those under pydicom's data/test_files,
data/charset_files and data/palettes (its wheel's), plus every file in each --extra folder
(for example the files pydicom downloads on demand, where a copy of them is at hand).

Each file gets one verdict:
    equal            volasso read it, and its voxels are pydicom's (frames in file order, or
                     reordered along the slice normal as volasso stacks them)
    lossy-near       volasso read a lossy file to values within 2 of pydicom's (another IDCT)
    differs          volasso read it to other values or another shape than pydicom's
    read-only-here   volasso read it and pydicom cannot decode it
    refused          volasso refused it with one line on stderr
    refused-unclear  volasso refused it with more or less than one line, or crashed
With --compare, the verdicts of an earlier --json run are compared file by file and every
change is printed. The exit status is 0 unless a file's verdict is `refused-unclear` or
`differs` in this run.

Never: changes or writes a file beside the inputs (volumes, and volasso's import cache, go to a
temporary folder).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import warnings

import numpy as np
import pydicom
from pydicom.pixels import apply_modality_lut

# Lossy JPEG, JPEG-LS near-lossless and JPEG 2000: two decoders may differ by 2 (ISO 10918-2
# allows each 1 from the exact IDCT; pydicom decodes 12-bit JPEG with libjpeg, volasso with
# libjpeg-turbo, as dcmtk does).
LOSSY = {"1.2.840.10008.1.2.4.50", "1.2.840.10008.1.2.4.51", "1.2.840.10008.1.2.4.81", "1.2.840.10008.1.2.4.91"}
SKIPPED_SUFFIXES = (".py", ".pyc", ".txt", ".json", ".md", ".icc", ".gz", ".dump")
NRRD_TYPES = {
    "uint8": "u1", "int8": "i1", "uint16": "u2", "int16": "i2", "short": "i2", "ushort": "u2",
    "uint32": "u4", "int32": "i4", "float": "f4", "double": "f8", "uchar": "u1",
}


def pydicom_files(extra):
    base = os.path.join(os.path.dirname(pydicom.__file__), "data")
    roots = [os.path.join(base, name) for name in ("test_files", "charset_files", "palettes")] + extra
    found = []
    for root in roots:
        for folder, _, names in os.walk(root):
            for name in names:
                if not name.endswith(SKIPPED_SUFFIXES) and "__pycache__" not in folder:
                    found.append(os.path.join(folder, name))
    return sorted(found), roots


def frame_rescales(ds, frames):
    """Each frame's (slope, intercept) from an enhanced file's Pixel Value Transformation
    functional groups (per-frame over shared), or None without them: `apply_modality_lut`
    reads only the top-level attributes."""
    def transformation(groups):
        items = groups.get("PixelValueTransformationSequence") if groups is not None else None
        if not items:
            return None
        return float(items[0].get("RescaleSlope", 1)), float(items[0].get("RescaleIntercept", 0))

    shared_items = ds.get("SharedFunctionalGroupsSequence")
    shared = transformation(shared_items[0]) if shared_items else None
    per_frame = ds.get("PerFrameFunctionalGroupsSequence") or [None] * frames
    rescales = [transformation(groups) or shared for groups in per_frame]
    return rescales if any(rescales) else None


def pydicom_values(path):
    """pydicom's voxels as (frames, rows, columns) float64, or the reason it has none."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = pydicom.dcmread(path)
            if int(ds.get("SamplesPerPixel", 1) or 1) != 1:
                return None, "colour"
            stored = ds.pixel_array
            values = apply_modality_lut(stored, ds).astype(np.float64)
    except Exception as error:  # pydicom raises many kinds; each is a reason here
        return None, f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}"
    frames = int(ds.get("NumberOfFrames", 1) or 1)
    if frames == 1:
        values = values[np.newaxis]
        stored = stored[np.newaxis]
    rescales = frame_rescales(ds, frames)
    if rescales is not None:
        values = np.stack([
            plane * rescale[0] + rescale[1] if rescale else plane
            for plane, rescale in zip(stored.astype(np.float64), rescales)
        ])
    # volasso keeps values as float32 where they are not all integers in int16's range.
    return values.astype(np.float32).astype(np.float64), None


def read_nrrd(path):
    with open(path, "rb") as file:
        data = file.read()
    end = data.index(b"\n\n")
    fields = {}
    for line in data[:end].decode().splitlines()[1:]:
        if ":" in line and not line.startswith("#"):
            key, value = line.split(":", 1)
            fields[key.strip()] = value.strip()
    if fields.get("encoding") != "raw":
        raise ValueError(f"encoding {fields.get('encoding')}")
    sizes = [int(size) for size in fields["sizes"].split()]
    order = ">" if fields.get("endian") == "big" else "<"
    dtype = np.dtype(order + NRRD_TYPES[fields["type"]])
    values = np.frombuffer(data[end + 2:], dtype=dtype, count=int(np.prod(sizes)))
    return values.reshape(sizes[::-1]).astype(np.float64)


def same_voxels(ours, theirs):
    """'equal', 'equal, frames reordered', or a description of the difference."""
    if ours.shape != theirs.shape:
        return f"shape {list(ours.shape)} against pydicom's {list(theirs.shape)} (frames, rows, columns)"
    if np.array_equal(ours, theirs):
        return "equal"
    unused = list(range(theirs.shape[0]))
    for plane in ours:
        match = next((index for index in unused if np.array_equal(plane, theirs[index])), None)
        if match is None:
            difference = np.abs(ours - theirs)
            return f"values differ: {int(np.count_nonzero(difference))} voxels, by up to {difference.max():g}"
        unused.remove(match)
    return "equal, frames reordered"


def verdict(volasso, path, scratch):
    out = os.path.join(scratch, "volume.nrrd")
    if os.path.exists(out):
        os.remove(out)
    try:
        environment = dict(os.environ, VOLASSO_CACHE_DIR=os.path.join(scratch, "cache"))
        run = subprocess.run(
            [volasso, "import", path, "--out", out], capture_output=True, text=True, timeout=120, env=environment
        )
    except subprocess.TimeoutExpired:
        return {"verdict": "refused-unclear", "detail": "timed out after 120 s"}
    theirs, why_not = pydicom_values(path)
    lines = [line for line in run.stderr.splitlines() if line.strip()]
    if run.returncode != 0:
        clear = len(lines) == 1 and "panicked" not in run.stderr and run.returncode == 1
        return {
            "verdict": "refused" if clear else "refused-unclear",
            "detail": " | ".join(lines) if lines else f"exit status {run.returncode}, nothing on stderr",
            "pydicom": why_not or "decodes",
        }
    ours = read_nrrd(out)
    if theirs is None:
        return {"verdict": "read-only-here", "detail": f"pydicom: {why_not}", "dims": list(ours.shape[::-1])}
    comparison = same_voxels(ours, theirs)
    lossy = str(pydicom.dcmread(path, stop_before_pixels=True).file_meta.get("TransferSyntaxUID", "")) in LOSSY
    if lossy and comparison.startswith("values differ") and np.abs(ours - theirs).max() <= 2:
        return {"verdict": "lossy-near", "detail": comparison, "dims": list(ours.shape[::-1])}
    return {
        "verdict": "equal" if comparison.startswith("equal") else "differs",
        "detail": comparison,
        "dims": list(ours.shape[::-1]),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("volasso")
    parser.add_argument("--extra", action="append", default=[], help="a folder of further DICOM files")
    parser.add_argument("--json", help="write every file's verdict here")
    parser.add_argument("--compare", help="an earlier --json run to compare with")
    args = parser.parse_args()
    files, roots = pydicom_files(args.extra)
    results = {}
    with tempfile.TemporaryDirectory() as scratch:
        for path in files:
            name = next(os.path.relpath(path, os.path.dirname(root)) for root in roots if path.startswith(root + os.sep))
            results[name] = verdict(args.volasso, path, scratch)
            print(f"{results[name]['verdict']:16} {name}: {results[name]['detail']}")
    counts = {}
    for result in results.values():
        counts[result["verdict"]] = counts.get(result["verdict"], 0) + 1
    print(f"pydicom {pydicom.__version__}, {len(results)} files: " + ", ".join(f"{n} {v}" for v, n in sorted(counts.items())))
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"pydicom": pydicom.__version__, "files": results}, file, indent=1, sort_keys=True)
    if args.compare:
        with open(args.compare) as file:
            before = json.load(file)["files"]
        changed = 0
        for name in sorted(set(before) | set(results)):
            old, new = before.get(name, {}), results.get(name, {})
            if (old.get("verdict"), old.get("detail")) != (new.get("verdict"), new.get("detail")):
                changed += 1
                print(f"changed {name}:\n  before {old.get('verdict')}: {old.get('detail')}\n  after  {new.get('verdict')}: {new.get('detail')}")
        print(f"{changed} of {len(results)} files changed verdict or detail")
    bad = [name for name, result in results.items() if result["verdict"] in ("differs", "refused-unclear")]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
