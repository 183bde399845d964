#!/usr/bin/env python3
"""Reads a DICOM Segmentation with highdicom, as 3D Slicer's and OHIF's readers do, and compares
it with a volasso label volume voxel for voxel.

Usage: seg_highdicom.py SEG.dcm SERIES_DIR LABELS.nrrd

The source slices are ordered here, independently of volasso, along the normal of their
ImageOrientationPatient by ImagePositionPatient; label slice z is the z-th of them, and within
a slice the label at (x, y) is the pixel at row y, column x (interfaces.md: x fastest). Prints
one JSON object: the segments (number, label, recommended display colour as sRGB 0-255 through
highdicom's CIELab conversion), the frames, and the voxels where the SEG and the labels differ.
Exits 1 (with the reason on stderr) when highdicom cannot read the file.
"""

import json
import os
import sys

import highdicom as hd
import numpy as np
import pydicom


def read_nrrd_uint8(path):
    with open(path, "rb") as f:
        data = f.read()
    header_end = data.index(b"\n\n")
    fields = {}
    for line in data[:header_end].decode("ascii").splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        key, value = line.split(":", 1)
        fields[key.strip()] = value.strip().lstrip("=").strip()
    assert fields["type"] in ("uint8", "uchar", "unsigned char"), fields["type"]
    assert fields.get("encoding", "raw") == "raw", fields.get("encoding")
    sizes = [int(s) for s in fields["sizes"].split()]
    voxels = np.frombuffer(data[header_end + 2:], dtype=np.uint8)
    assert voxels.size == sizes[0] * sizes[1] * sizes[2], (voxels.size, sizes)
    return voxels.reshape(sizes[2], sizes[1], sizes[0])  # [z, y, x]


def source_slices(folder):
    slices = []
    for root, _, names in os.walk(folder):
        for name in names:
            try:
                ds = pydicom.dcmread(os.path.join(root, name), stop_before_pixels=True)
            except Exception:
                continue
            if "ImagePositionPatient" not in ds or "Rows" not in ds:
                continue
            row, column = np.array(ds.ImageOrientationPatient[:3], float), np.array(ds.ImageOrientationPatient[3:], float)
            normal = np.cross(row, column)
            slices.append((float(np.dot(normal, np.array(ds.ImagePositionPatient, float))), ds.SOPInstanceUID))
    slices.sort()
    return [uid for _, uid in slices]


def main():
    seg_path, series, labels_path = sys.argv[1:4]
    seg = hd.seg.segread(seg_path)
    labels = read_nrrd_uint8(labels_path)
    uids = source_slices(series)
    segments = []
    for number in seg.segment_numbers:
        description = seg.get_segment_description(number)
        lab = hd.color.CIELabColor.from_dicom_value(description.RecommendedDisplayCIELabValue)
        segments.append({"number": int(number), "label": description.segment_label, "rgb": list(lab.to_rgb(clip=True))})
    pixels = seg.get_pixels_by_source_instance(
        source_sop_instance_uids=uids, combine_segments=True, skip_overlap_checks=False
    )
    pixels = np.asarray(pixels)
    if pixels.shape != labels.shape:
        print(json.dumps({"segments": segments, "shape": list(pixels.shape), "labels_shape": list(labels.shape)}))
        return
    differ = int(np.count_nonzero(pixels.astype(np.int64) != labels.astype(np.int64)))
    counts = {str(k): int(np.count_nonzero(pixels == k)) for k in seg.segment_numbers}
    print(json.dumps({
        "segments": segments,
        "frames": int(seg.NumberOfFrames),
        "shape": list(pixels.shape),
        "labels_shape": list(labels.shape),
        "differing_voxels": differ,
        "voxels_per_segment": counts,
        "study_uid": seg.StudyInstanceUID,
        "frame_of_reference_uid": seg.FrameOfReferenceUID,
    }))


if __name__ == "__main__":
    try:
        main()
    except Exception as error:  # one line saying why, for the test's message
        print(f"seg_highdicom.py: {type(error).__name__}: {error}", file=sys.stderr)
        sys.exit(1)
