#!/usr/bin/env python3
"""An accuracy check volasso's own harness cannot be tuned to.

`volasso accuracy` draws its phantoms (crates/volasso-core/src/phantom) and its user (crates/volasso-core/src/accuracy/user.rs) with
the same code base that chooses the defaults. This script makes everything again without that
code: its own phantoms (numpy/scipy: an abdominal CT, a T1 head MRI with a bias field and Rician
noise, a CT vessel tree, a knee CT with a thin joint gap, a noisy cell culture MRI, a CT
angiogram of vessels 1-3 voxels across with small calcifications, a chest CT in a mediastinal
window whose lungs are as black as the air and leave through the top face, a liver CT whose
dark lesions and thin bright vessels lie inside the liver's loop; and a real brain,
the ICBM 152 T1 template that nilearn ships, with its tissue maps as truth), its own
finger (loops on the three slices `volasso info` ranks first, drawn inside each structure or
leaking 2 voxels over its border, into air too; `--hands` adds a finger that lands off-centre and
a broad one 4 voxels over), and its own scoring. It runs the volasso binary
as a user would (`volasso info`, `volasso classify` on an NRRD file) and scikit-learn's random
forest (100 trees) on the paper's 5 features computed here, on the same lassoed voxels.

One more case scores what a class holds rather than Dice: on the T1 head, a loop around a
lateral ventricle (the leaky finger takes the white matter beside it), one in white matter and
one on the scalp; it prints the share of the ventricle's class inside the brain that is CSF,
the share of the grey matter it took, and the share of the ventricles it found.

It prints, per case and hand, the macro Dice of both, the share of the air around the body
(in each axial slice, the air joined to the slice's edge) that got a class when the air was not
lassoed, and the share of lassoed voxels
that kept their class; then the means per hand and the worst difference to the forest.
`--thick N` cuts every scan in slices N times as thick (the mean of N, truth their majority).

`--presets` also scores learned presets: each seed's clean classification is saved as a preset
(`--save-preset`, with `--modality` ct or mr from the case's kind) and applied with no loops to
the next seed's scan of the same case whose loops took the same classes (air lassoed or not;
the last to the first), so both are scored on the same classes; the MRI cases' scans are given
another receiver gain first (x1.4, x0.75 for 8-bit ones) on top of their own bias field. It
prints each application's macro Dice beside the target's own clean loops' and, per case, the
mean of both.

Usage: python3 scripts/heldout.py [--volasso target/release/volasso] [--seeds 101,102,103]
                                  [--only NAME[,NAME]] [--forest-cache DIR] [--keep DIR] [--classify-args="--coherence none"]
                                  [--hands clean,leaky,offset,wide] [--thick N] [--presets]
Needs numpy, scipy, scikit-image and scikit-learn (pip install numpy scipy scikit-image scikit-learn);
the real brain (mni-t1) also nilearn's data files: pip install nilearn, or unpack its wheel
(pip download nilearn --no-deps) and set VOLASSO_MNI_DIR to its nilearn/datasets/data folder.
Without them that case is skipped.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy import ndimage as ndi

AIR = 0


def smooth_field(shape, sigma, rng):
    """Zero-mean, unit-deviation noise smoothed over `sigma` voxels."""
    field = ndi.gaussian_filter(rng.standard_normal(shape), sigma)
    return (field - field.mean()) / (field.std() + 1e-12)


def grid(shape):
    return np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij")


def finish(mean, noise, blur, rng, dtype, rician=False):
    """The image of a noise-free `mean` image: a point spread, noise, rounding to `dtype`."""
    image = ndi.gaussian_filter(mean.astype(np.float64), blur)
    if rician:
        image = np.hypot(image + noise * rng.standard_normal(image.shape), noise * rng.standard_normal(image.shape))
    else:
        image = image + noise * rng.standard_normal(image.shape)
    info = np.iinfo(dtype)
    return np.clip(np.rint(image), info.min, info.max).astype(dtype)


# Each phantom returns (image z,y,x; truth z,y,x; class names by truth id; spacing x,y,z).


def abdomen_ct16(rng):
    shape = (40, 112, 128)
    z, y, x = grid(shape)
    wobble = 0.06 * smooth_field(shape, 10, rng)
    body = ((x - 64) / 58) ** 2 + ((y - 56) / 44) ** 2 < 1 + wobble
    truth = np.zeros(shape, np.uint8)
    truth[body] = 1  # fat
    muscle = ((x - 64) / 52) ** 2 + ((y - 56) / 38) ** 2 < 1 + wobble
    truth[muscle] = 2
    liver = (((x - 40) / 24) ** 2 + ((y - 50) / 20) ** 2 + ((z - 20) / 26) ** 2
             < 1 + 0.15 * smooth_field(shape, 6, rng))
    truth[liver & muscle] = 3
    aorta = ((x - 70) ** 2 + (y - 66) ** 2) < (4.0 + 0.5 * np.sin(z / 6)) ** 2
    truth[aorta] = 4
    spine = ((x - 64) / 10) ** 2 + ((y - 84) / 8) ** 2 < 1
    truth[spine] = 5
    values = np.array([-1000, -95, 45, 115, 260, 650], np.float64)
    image = finish(values[truth], 22, 0.8, rng, np.int16)
    return image, truth, ["air", "fat", "muscle", "liver", "aorta", "spine"], (0.8, 0.8, 2.5)


def head_t1_16(rng, values=(0, 820, 120, 260, 520, 720), bias=0.22):
    shape = (72, 88, 76)
    z, y, x = grid(shape)
    r = np.sqrt(((x - 38) / 34) ** 2 + ((y - 44) / 40) ** 2 + ((z - 40) / 34) ** 2)
    r = r + 0.03 * smooth_field(shape, 8, rng)
    truth = np.zeros(shape, np.uint8)
    truth[r < 1.0] = 1  # scalp
    truth[r < 0.92] = 2  # skull
    truth[r < 0.85] = 3  # CSF
    folds = 0.07 * smooth_field(shape, 2.5, rng)
    truth[r < 0.81 + 0.5 * folds] = 4  # grey matter
    truth[r < 0.68 + folds] = 5  # white matter
    ventricles = ((np.abs(x - 38) - 6) / 4) ** 2 + ((y - 46) / 12) ** 2 + ((z - 42) / 8) ** 2 < 1
    truth[ventricles & (r < 0.6)] = 3
    truth[z < 8] = np.where(truth[z < 8] > 0, 1, 0)  # the neck: soft tissue down to the face
    values = np.array(values, np.float64)
    image = ndi.gaussian_filter(values[truth].astype(np.float64), 0.7)
    image *= 1 + bias * smooth_field(shape, 25, rng)
    sigma = 28
    image = np.hypot(image + sigma * rng.standard_normal(shape), sigma * rng.standard_normal(shape))
    image = np.clip(np.rint(image), 0, 65535).astype(np.uint16)
    return image, truth, ["background", "scalp", "skull", "csf", "grey", "white"], (1.0, 1.0, 1.2)


def head_ventricles_t1_16(rng):
    """The T1 head with its lateral ventricles as a class of their own ("ventricle", CSF to the
    scanner); drawn: a loop around a ventricle, one in white matter and one on the scalp
    (`DRAWN`); scored by what the ventricle's class holds (`ventricle_purity`). Grey matter lies
    nearer the white matter than the CSF, as in a 3 T MPRAGE (grey at about 0.65 of the white
    matter's signal, CSF at 0.3), with a 12 % bias field: a class drawn around the ventricles
    has no reason to take the grey matter but the white matter its loop took in."""
    image, truth, names, spacing = head_t1_16(rng, values=(0, 820, 120, 260, 580, 760), bias=0.12)
    z, y, x = grid(truth.shape)
    ventricles = ((np.abs(x - 38) - 6) / 4) ** 2 + ((y - 46) / 12) ** 2 + ((z - 42) / 8) ** 2 < 1
    truth = truth.copy()
    truth[ventricles & (truth == 3)] = 6
    # The white matter's loop is drawn in white matter, not around the ventricles.
    draw = truth.copy()
    draw[(draw == 5) & ndi.binary_dilation(truth == 6, iterations=6)] = 0
    return image, truth, names + ["ventricle"], spacing, draw


def vessels_ct8(rng):
    shape = (64, 96, 96)
    z, y, x = grid(shape)
    truth = np.zeros(shape, np.uint8)
    body = ((x - 48) / 44) ** 2 + ((y - 48) / 42) ** 2 < 1 + 0.05 * smooth_field(shape, 10, rng)
    truth[body] = 1  # soft tissue
    organ = ((x - 34) / 18) ** 2 + ((y - 40) / 16) ** 2 + ((z - 30) / 20) ** 2 < 1
    truth[organ & body] = 2
    # A branching tree of tubes, radius 1.2 to 3 voxels.
    tubes = vessel_tree(shape, (32.0, 48.0, 60.0), 3.0, rng, min_radius=1.2, shrink=0.75)
    truth[tubes & body] = 3
    bone = (((x - 66) / 7) ** 2 + ((y - 70) / 7) ** 2 < 1) & body
    truth[bone] = 4
    values = np.array([8, 92, 124, 182, 236], np.float64)
    image = finish(values[truth], 9, 0.7, rng, np.uint8)
    return image, truth, ["air", "soft tissue", "organ", "vessels", "bone"], (0.7, 0.7, 1.0)


def knee_ct16(rng):
    shape = (96, 72, 72)
    z, y, x = grid(shape)
    truth = np.zeros(shape, np.uint8)
    leg = ((x - 36) / 30) ** 2 + ((y - 36) / 28) ** 2 < 1 + 0.05 * smooth_field(shape, 10, rng)
    truth[leg] = 1
    gap = 48 + 3 * np.sin(x / 9) + 2 * np.cos(y / 11)
    shaft = ((x - 36) / 16) ** 2 + ((y - 37) / 14) ** 2 < 1
    femur = shaft & (z > gap + 2)
    tibia = shaft & (z < gap - 2)
    joint = shaft & ~femur & ~tibia
    truth[femur | tibia] = 2
    truth[joint] = 3
    marrow = ((x - 36) / 12.5) ** 2 + ((y - 37) / 10.5) ** 2 < 1
    values = np.array([-1000, 40, 1150, 90], np.float64)
    mean = values[truth].astype(np.float64)
    mean[(truth == 2) & marrow & (np.abs(z - gap) > 6)] = 320  # marrow is bone too, but darker
    image = finish(mean, 25, 0.8, rng, np.int16)
    return image, truth, ["air", "soft tissue", "bone", "joint"], (0.6, 0.6, 0.6)


def cells_mri8(rng):
    shape = (48, 96, 96)
    z, y, x = grid(shape)
    truth = np.zeros(shape, np.uint8)  # culture medium
    for _ in range(14):
        c = rng.uniform([6, 10, 10], [42, 86, 86])
        radii = rng.uniform([5, 7, 7], [8, 12, 12])
        cell = (((z - c[0]) / radii[0]) ** 2 + ((y - c[1]) / radii[1]) ** 2 + ((x - c[2]) / radii[2]) ** 2) < 1
        truth[cell] = 1
        nucleus = (((z - c[0]) / (radii[0] * 0.45)) ** 2 + ((y - c[1]) / (radii[1] * 0.45)) ** 2
                   + ((x - c[2]) / (radii[2] * 0.45)) ** 2) < 1
        truth[nucleus] = 2
    granules = rng.uniform(0, 1, shape) < 0.0003
    truth[ndi.binary_dilation(granules, iterations=2) & (truth == 0)] = 3
    values = np.array([40, 105, 165, 250], np.float64)
    biased = np.clip(np.rint(values[truth] * (1 + 0.15 * smooth_field(shape, 20, rng))), 0, 255)
    image = finish(biased, 16, 0.6, rng, np.uint8, rician=True)
    return image, truth, ["medium", "cell", "nucleus", "granules"], (0.5, 0.5, 1.0)


def vessel_tree(shape, start, radius, rng, min_radius=0.5, max_steps=400, shrink=0.72):
    """A branching tree of tubes from `start` (z, y, x) along +z, radius `radius` voxels down to
    `min_radius`, each branch a random walk that forks in two, `shrink` times thinner, where it
    ends."""
    tubes = np.zeros(shape, bool)
    walkers = [(np.asarray(start, float), np.array([1.0, 0.0, 0.0]), radius)]
    steps = 0
    while walkers and steps < max_steps:
        steps += 1
        pos, direction, radius = walkers.pop(0)
        for _ in range(int(rng.integers(12, 28))):
            direction = direction + 0.25 * rng.standard_normal(3)
            direction /= np.linalg.norm(direction)
            pos = pos + direction
            if not all(2 <= pos[i] < shape[i] - 2 for i in range(3)):
                break
            lo = np.maximum(np.floor(pos - radius - 1).astype(int), 0)
            hi = np.minimum(np.ceil(pos + radius + 2).astype(int), shape)
            sub = tuple(slice(lo[i], hi[i]) for i in range(3))
            zz, yy, xx = np.meshgrid(*[np.arange(lo[i], hi[i]) for i in range(3)], indexing="ij")
            tubes[sub] |= (zz - pos[0]) ** 2 + (yy - pos[1]) ** 2 + (xx - pos[2]) ** 2 <= max(radius, 0.5) ** 2
        else:
            if radius > min_radius + 0.1:
                for turn in (-1, 1):
                    side = direction + 0.8 * turn * np.cross(direction, rng.standard_normal(3))
                    walkers.append((pos.copy(), side / np.linalg.norm(side), max(min_radius, radius * shrink)))
    return tubes


def thin_vessels_ct16(rng):
    """A CT angiogram of thin vessels: a tree of contrast-filled tubes 1 to 3 voxels across in
    soft tissue and fat, with small calcifications (2-3 voxels) beside them and in the tissue."""
    shape = (56, 96, 96)
    z, y, x = grid(shape)
    truth = np.zeros(shape, np.uint8)
    body = ((x - 48) / 44) ** 2 + ((y - 48) / 42) ** 2 < 1 + 0.05 * smooth_field(shape, 10, rng)
    truth[body] = 1  # fat
    tissue = ((x - 48) / 38) ** 2 + ((y - 48) / 36) ** 2 < 1 + 0.08 * smooth_field(shape, 8, rng)
    truth[tissue & body] = 2  # soft tissue
    tubes = np.zeros(shape, bool)
    for start in ((3, 40, 36), (3, 56, 60), (28, 30, 60)):
        tubes |= vessel_tree(shape, start, 1.5, rng, min_radius=0.5, max_steps=60)
    truth[tubes & tissue] = 3
    calcified = np.zeros(shape, bool)
    for _ in range(24):
        c = rng.uniform([6, 20, 20], [50, 76, 76])
        r = rng.uniform(0.9, 1.5)
        calcified |= (z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2 <= r ** 2
    truth[calcified & tissue] = 4
    values = np.array([-1000, -90, 45, 330, 900], np.float64)
    image = finish(values[truth], 18, 0.6, rng, np.int16)
    return image, truth, ["air", "fat", "soft tissue", "vessels", "calcification"], (0.6, 0.6, 0.8)


def chest_ct8(rng):
    """A chest CT in a mediastinal window, stored as 8 bits: the lungs are as black as the air
    outside, and they reach the volume's top face through the trachea and their apices."""
    shape = (64, 100, 128)
    z, y, x = grid(shape)
    truth = np.zeros(shape, np.uint8)
    wobble = 0.05 * smooth_field(shape, 12, rng)
    body = ((x - 64) / 58) ** 2 + ((y - 50) / 40) ** 2 < 1 + wobble
    truth[body] = 1  # fat under the skin
    wall = ((x - 64) / 54) ** 2 + ((y - 50) / 36) ** 2 < 1 + wobble
    truth[wall] = 2  # muscle and mediastinum
    cage = ((x - 64) / 49) ** 2 + ((y - 50) / 31) ** 2 < 1 + wobble  # inside the ribs and intercostal muscle
    lungs = np.zeros(shape, bool)
    for side in (-1, 1):
        cx = 64 + side * 25
        lungs |= (((x - cx) / 20) ** 2 + ((y - 47) / 27) ** 2 + ((z - 58) / 52) ** 2
                  < 1 + 0.1 * smooth_field(shape, 8, rng))
    lungs &= cage & (z > 6)
    trachea = ((x - 64) ** 2 + (y - 36) ** 2 < 5.0 ** 2) & (z > 40)
    truth[(lungs | trachea) & wall] = 3
    ribs = np.zeros(shape, bool)
    rib_shell = (((x - 64) / 51) ** 2 + ((y - 50) / 34) ** 2)
    for k in range(7):
        ribs |= (np.abs(np.sqrt(rib_shell) - 0.965) < 0.035) & (np.abs(z - (6 + 8.5 * k + 2 * np.sin(x / 30))) < 1.6)
    spine = ((x - 64) / 9) ** 2 + ((y - 80) / 8) ** 2 < 1
    truth[(ribs | spine) & wall & ~lungs] = 4
    hu = np.array([-1000, -100, 40, -850, 700], np.float64)
    mean = hu[truth]
    vessels = lungs & (smooth_field(shape, 1.5, rng) > 2.2)
    mean[vessels] = 20  # vessels in the lung: lung all the same to the truth, bright on the picture
    image = ndi.gaussian_filter(mean, 0.8) + 30 * rng.standard_normal(shape)
    windowed = (image - (40 - 200)) / 400 * 255  # level 40, width 400
    image = np.clip(np.rint(windowed), 0, 255).astype(np.uint8)
    return image, truth, ["air", "fat", "soft tissue", "lung", "bone"], (0.8, 0.8, 2.0)


def liver_lesions_ct16(rng):
    """A portal-venous CT of the liver: dark lesions (cysts, round, 6 to 14 voxels across in the
    plane) and a tree of bright vessels 1 to 3 voxels across inside an enhancing liver, with fat,
    muscle and the spine around it. A loop around the liver takes in lesions and vessels, drawn
    or not; a lesion's loop lies inside the liver's."""
    shape = (44, 112, 128)
    z, y, x = grid(shape)
    wobble = 0.05 * smooth_field(shape, 10, rng)
    truth = np.zeros(shape, np.uint8)
    truth[((x - 64) / 60) ** 2 + ((y - 56) / 46) ** 2 < 1 + wobble] = 1  # fat
    muscle = ((x - 64) / 54) ** 2 + ((y - 56) / 40) ** 2 < 1 + wobble
    truth[muscle] = 2
    liver = muscle & ((((x - 46) / 30) ** 2 + ((y - 50) / 26) ** 2 + ((z - 22) / 30) ** 2)
                      < 1 + 0.12 * smooth_field(shape, 6, rng))
    truth[liver] = 3
    vessels = vessel_tree(shape, (2, 48, 44), 1.6, rng, min_radius=0.5, max_steps=50)
    truth[vessels & liver] = 5
    inside = np.argwhere(liver & (z > 6) & (z < shape[0] - 6))  # where a lesion's centre may lie
    for _ in range(int(rng.integers(4, 7))):
        c = inside[rng.integers(len(inside))]
        r = rng.uniform(3.0, 7.0)
        truth[liver & ((((z - c[0]) * 2.5) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2) < r ** 2)] = 4
    truth[((x - 64) / 10) ** 2 + ((y - 88) / 8) ** 2 < 1] = 6  # spine
    hu = np.array([-1000, -100, 50, 115, 10, 190, 650], np.float64)
    image = finish(hu[truth], 16, 0.8, rng, np.int16)
    return image, truth, ["air", "fat", "muscle", "liver", "lesion", "vessels", "bone"], (0.8, 0.8, 2.0)


MNI_FILES = "mni_icbm152_{}_tal_nlin_sym_09a_converted.nii.gz"


def mni_folder():
    """The folder of the ICBM 152 2009a template nilearn ships (its T1 image and its grey and
    white matter maps), from $VOLASSO_MNI_DIR or the installed nilearn; None when neither."""
    folder = os.environ.get("VOLASSO_MNI_DIR")
    if not folder:
        try:
            import nilearn
        except ImportError:
            return None
        folder = os.path.join(os.path.dirname(nilearn.__file__), "datasets", "data")
    return folder if os.path.exists(os.path.join(folder, MNI_FILES.format("t1"))) else None


def read_nifti_gz(path):
    """A gzipped NIfTI-1 volume as (z, y, x), read without nibabel."""
    import gzip

    data = gzip.open(path, "rb").read()
    if int(np.frombuffer(data[:4], "<i4")[0]) != 348:
        raise ValueError(f"{path}: not a little-endian NIfTI-1 file")
    dims = np.frombuffer(data[40:56], "<i2")
    datatype = int(np.frombuffer(data[70:72], "<i2")[0])
    offset = int(np.frombuffer(data[108:112], "<f4")[0])
    kind = {2: np.uint8, 4: np.int16, 16: np.float32, 512: np.uint16}[datatype]
    x, y, z = (int(n) for n in dims[1:4])
    return np.frombuffer(data[offset:], kind, count=x * y * z).reshape(z, y, x)


def mni_t1(rng):
    """A real brain: the ICBM 152 template (an average of 152 T1 MRIs, skull-stripped, 1 mm) with
    its tissue maps as truth (cerebrospinal fluid where grey and white matter leave the most
    probability), scanned again with a bias field (a deviation of 2 to 6 %, about BrainWeb's 20 % field) and Rician
    noise of 3 to 5 % of the white matter."""
    folder = mni_folder()
    t1, grey, white = (read_nifti_gz(os.path.join(folder, MNI_FILES.format(n))).astype(np.float64)
                       for n in ("t1", "gm", "wm"))
    inside = t1 > 0
    csf = np.clip(255 - grey - white, 0, None)
    truth = (np.argmax(np.stack([csf, grey, white]), 0) + 1).astype(np.uint8)
    truth[~inside] = 0
    # The brain's box and 6 voxels around it (the template's brain stem reaches its lowest plane).
    lo = np.maximum(np.argwhere(inside).min(0) - 6, 0)
    hi = np.argwhere(inside).max(0) + 7
    box = tuple(slice(a, b) for a, b in zip(lo, hi))
    t1, truth = t1[box], truth[box]
    shape = t1.shape
    image = 8 * t1 * (1 + rng.uniform(0.02, 0.06) * smooth_field(shape, 30, rng))
    sigma = 8 * 215 * rng.uniform(0.03, 0.05)
    image = np.hypot(image + sigma * rng.standard_normal(shape), sigma * rng.standard_normal(shape))
    image = np.clip(np.rint(image), 0, 65535).astype(np.uint16)
    return image, truth, ["background", "csf", "grey", "white"], (1.0, 1.0, 1.0)


PHANTOMS = {"abdomen-ct16": abdomen_ct16, "head-t1-16": head_t1_16, "vessels-ct8": vessels_ct8,
            "knee-ct16": knee_ct16, "cells-mri8": cells_mri8, "mni-t1": mni_t1,
            "thin-vessels-ct16": thin_vessels_ct16, "chest-ct8": chest_ct8,
            "head-ventricle-t1": head_ventricles_t1_16, "liver-lesions-ct16": liver_lesions_ct16}
# Cases where only some classes are drawn (truth ids, in drawing order); the rest draw every class.
DRAWN = {"head-ventricle-t1": [6, 5, 1]}
# Phantoms whose class 0 is air around a body: the user may leave it unlassoed.
WITH_AIR = {"abdomen-ct16", "head-t1-16", "vessels-ct8", "knee-ct16", "mni-t1", "thin-vessels-ct16", "chest-ct8",
            "head-ventricle-t1", "liver-lesions-ct16"}


def thick_slices(image, truth, spacing, count):
    """The scan cut in slices `count` times as thick: each new slice the mean of `count` slices
    along z (a thick slice's partial volume), its truth the class most of them hold."""
    if count <= 1:
        return image, truth, spacing
    z, info = image.shape[0] // count * count, np.iinfo(image.dtype)
    mean = image[:z].astype(np.float64).reshape(z // count, count, *image.shape[1:]).mean(axis=1)
    stacked = truth[:z].reshape(z // count, count, *truth.shape[1:])
    votes = np.stack([(stacked == c).sum(axis=1) for c in range(int(truth.max()) + 1)])
    return (np.clip(np.rint(mean), info.min, info.max).astype(image.dtype), votes.argmax(axis=0).astype(np.uint8),
            (spacing[0], spacing[1], spacing[2] * count))


def write_nrrd(path, image, spacing):
    kind = {np.dtype(np.uint8): "uint8", np.dtype(np.int16): "int16", np.dtype(np.uint16): "uint16"}[image.dtype]
    z, y, x = image.shape
    header = (f"NRRD0004\ntype: {kind}\ndimension: 3\nsizes: {x} {y} {z}\n"
              f"spacings: {spacing[0]} {spacing[1]} {spacing[2]}\nencoding: raw\nendian: little\n\n")
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(np.ascontiguousarray(image).astype(image.dtype.newbyteorder("<")).tobytes())


def read_nrrd_labels(path, shape):
    with open(path, "rb") as f:
        data = f.read()
    body = data[data.index(b"\n\n") + 2:]
    return np.frombuffer(body, np.uint8).reshape(shape)


def plane(volume, axis, index):
    """The slice image as the strokes file addresses it: [row j][column i] for point (i, j)."""
    if axis == "z":
        return volume[index, :, :]  # (y, x): point [x, y]
    if axis == "y":
        return volume[:, index, :]  # (z, x): point [x, z]
    return volume[:, :, index]  # (z, y): point [y, z]


HANDS = ["clean", "leaky", "offset", "wide"]


def finger_loop(component, hand, rng):
    """A closed polygon (points [i, j]) a finger draws around part of a 2-D region."""
    from skimage.measure import find_contours

    depth = ndi.distance_transform_edt(component)
    j0, i0 = np.unravel_index(np.argmax(depth), depth.shape)
    jj, ii = np.indices(component.shape)
    reach = 14 if depth.max() >= 5 else 22
    region = component & ((jj - j0) ** 2 + (ii - i0) ** 2 <= reach ** 2)
    region = ndi.label(region)[0] == ndi.label(region)[0][j0, i0]
    if hand == "clean":
        inner = ndi.binary_erosion(region, iterations=1)
        if inner.sum() >= 3:
            region = inner
        jitter = 0.3
    elif hand == "leaky":
        region = ndi.binary_dilation(region, structure=np.ones((3, 3)), iterations=2)
        jitter = 0.8
    elif hand == "offset":  # lands off-centre: over the border on one side, short of it on the other
        angle = rng.uniform(0, 2 * np.pi)
        shifted = ndi.shift(region.astype(float), (2.5 * np.sin(angle), 2.5 * np.cos(angle)), order=0) > 0.5
        region = ndi.binary_dilation(shifted if shifted.any() else region, structure=np.ones((3, 3)))
        jitter = 0.8
    else:  # "wide": a broad fingertip on a small panel, 4 voxels over the border
        region = ndi.binary_dilation(region, structure=np.ones((3, 3)), iterations=4)
        jitter = 1.2
    padded = np.pad(region.astype(float), 1)
    contour = max(find_contours(padded, 0.5), key=len) - 1  # (row j, column i)
    step = max(1, len(contour) // 48)
    points = contour[::step] + jitter * rng.standard_normal((len(contour[::step]), 2))
    return [[float(p[1]), float(p[0])] for p in points]


def largest_component(mask):
    """The largest connected part of a 2-D mask; None when the mask is empty."""
    parts, count = ndi.label(mask)
    if count == 0:
        return None
    sizes = ndi.sum(mask, parts, range(1, count + 1))
    return parts == 1 + int(np.argmax(sizes))


def draw_strokes(truth, names, lasso_air, top_slices, hand, rng, drawn=None):
    classes, class_truth = [], []
    order = drawn if drawn is not None else range(len(names))
    for cls in order:
        name = names[cls]
        if cls == AIR and not lasso_air:
            continue
        strokes = []
        for axis, index in zip("xyz", top_slices):
            mask = plane(truth, axis, index) == cls
            component = largest_component(mask)
            if component is None or component.sum() < 4:
                continue
            strokes.append({"axis": axis, "slice": int(index), "points": finger_loop(component, hand, rng)})
        if not strokes:  # not on the ranked slices: the user pages to the z slice that shows most of it
            index = int(np.argmax((truth == cls).sum(axis=(1, 2))))
            component = largest_component(plane(truth, "z", index) == cls)
            strokes.append({"axis": "z", "slice": index, "points": finger_loop(component, hand, rng)})
        classes.append({"name": name, "strokes": strokes})
        class_truth.append(cls)
    return {"format": "volasso-strokes/1", "classes": classes}, class_truth


def inside_polygon(points, ii, jj):
    """Even-odd rule for voxel centres (ii, jj), as the strokes contract says."""
    inside = np.zeros(ii.shape, bool)
    p = np.asarray(points)
    for (xa, ya), (xb, yb) in zip(p, np.roll(p, -1, axis=0)):
        crosses = (ya > jj) != (yb > jj)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = xa + (jj - ya) * (xb - xa) / (yb - ya)
        inside ^= crosses & (ii < x_at)
    return inside


def lassoed_voxels(strokes, shape):
    """Per class, a mask of the voxels inside its polygons."""
    masks = []
    for entry in strokes["classes"]:
        mask = np.zeros(shape, bool)
        for stroke in entry["strokes"]:
            view = plane(mask, stroke["axis"], stroke["slice"])
            jj, ii = np.indices(view.shape)
            view |= inside_polygon(stroke["points"], ii, jj)
        masks.append(mask)
    return masks


def paper_features(image):
    """Intensity, gradient magnitude, and the 8-neighbour means in the xy, xz and yz planes."""
    v = image.astype(np.float32)
    gz, gy, gx = np.gradient(v)
    ring = np.ones((3, 3), np.float32)
    ring[1, 1] = 0
    ring /= 8
    means = [ndi.convolve(v, ring[axis_shape], mode="nearest") for axis_shape in
             (np.s_[None, :, :], np.s_[:, None, :], np.s_[:, :, None])]
    return np.stack([v, np.sqrt(gx ** 2 + gy ** 2 + gz ** 2)] + means, axis=-1).reshape(-1, 5)


def forest_labels(image, masks, lasso_air):
    from sklearn.ensemble import RandomForestClassifier
    from skimage.filters import threshold_otsu

    features = paper_features(image)
    train = np.concatenate([np.flatnonzero(m) for m in masks])
    target = np.concatenate([np.full(int(m.sum()), k + 1) for k, m in enumerate(masks)])
    forest = RandomForestClassifier(n_estimators=100, random_state=0, n_jobs=-1)
    labels = forest.fit(features[train], target).predict(features).astype(np.uint8)
    if not lasso_air:
        labels[features[:, 0] < threshold_otsu(image)] = 0
    return labels.reshape(image.shape)


def cached_forest_labels(folder, image, strokes, masks, lasso_air):
    """`forest_labels`, kept in `folder` (when given) under a hash of the image and the strokes:
    the forest is the slowest part of a run and does not change with volasso."""
    if not folder:
        return forest_labels(image, masks, lasso_air)
    import hashlib

    key = hashlib.sha256(image.tobytes() + json.dumps(strokes, sort_keys=True).encode()
                         + bytes([lasso_air])).hexdigest()[:32]
    path = os.path.join(folder, key + ".npy")
    if os.path.exists(path):
        return np.load(path)
    labels = forest_labels(image, masks, lasso_air)
    os.makedirs(folder, exist_ok=True)
    np.save(path + ".tmp.npy", labels)
    os.replace(path + ".tmp.npy", path)
    return labels


def dice(truth, predicted, cls):
    t, p = truth == cls, predicted == cls
    total = t.sum() + p.sum()
    return 1.0 if total == 0 else 2.0 * np.logical_and(t, p).sum() / total


def score(truth, labels, class_truth, names, masks, lasso_air):
    lookup = np.zeros(256, np.uint8)
    for k, cls in enumerate(class_truth):
        lookup[k + 1] = cls
    predicted = lookup[labels]
    per_class = [dice(truth, predicted, c) for c in range(len(names))]
    face_air = air_around_the_body(truth == AIR)
    air_classed = float((labels[face_air] > 0).mean()) if (not lasso_air and face_air.any()) else None
    # A lassoed air's voxels kept as background (label 0: not drawn in 3-D) keep their class.
    kept = min((float(((labels[m] == k + 1) | ((labels[m] == 0) & (class_truth[k] == AIR))).mean())
                for k, m in enumerate(masks)), default=1.0)
    return float(np.mean(per_class)), per_class, air_classed, kept


def air_around_the_body(air):
    """The air a radiologist calls outside: in each axial (z) slice, the air that a path of air
    joins to the slice's edge. Lungs and airways, ringed by the chest wall in every axial slice,
    are not in it, even where they leave the volume through a face; nor are an MRI's ventricles
    where a crop makes its darkest level reach a face."""
    outside = np.zeros(air.shape, bool)
    four = ndi.generate_binary_structure(2, 1)
    for z in range(air.shape[0]):
        parts, _ = ndi.label(air[z], structure=four)
        edge = np.unique(np.concatenate([parts[0], parts[-1], parts[:, 0], parts[:, -1]]))
        outside[z] = np.isin(parts, edge[edge > 0])
    return outside


def ventricle_purity(truth, labels, class_truth):
    """What the ventricle's class holds inside the brain (CSF, grey and white matter): its share
    of CSF (the ventricles and the CSF around the brain); the share of all grey matter it took;
    the share of the ventricles it found."""
    label = class_truth.index(6) + 1
    mine = labels == label
    brain = np.isin(truth, (3, 4, 5, 6))
    inside = max(int((mine & brain).sum()), 1)
    return (float(np.isin(truth[mine], (3, 6)).sum() / inside), float(mine[truth == 4].mean()),
            float(mine[truth == 6].mean()))


def modality_args(name):
    """`--modality` for a case, as a DICOM series would say it: its kind from its name (ct, mri
    or t1)."""
    if "-ct" in name:
        return ["--modality", "ct"]
    if "mri" in name or "t1" in name:
        return ["--modality", "mr"]
    return []


def preset_pairs(made_cases):
    """(source, target) seeds: each seed and the next one whose loops took the same classes
    (air lassoed or not), the last of those back to the first."""
    pairs = []
    for lasso_air in (False, True):
        seeds = sorted(seed for seed, case in made_cases.items() if case[4] == lasso_air)
        if len(seeds) >= 2:
            pairs.extend(zip(seeds, seeds[1:] + seeds[:1]))
    return pairs


def apply_presets(args, folder, name, names, made_cases):
    """Each seed's preset applied with no loops to the next seed's scan (an MRI's with another
    receiver gain); rows (case, from seed, to seed, preset Dice, own clean loops' Dice)."""
    rows = []
    for source, target in preset_pairs(made_cases):
        image, truth, spacing, _, _, own, _ = made_cases[target]
        _, _, _, class_truth, lasso_air, _, preset = made_cases[source]
        if modality_args(name)[-1:] == ["mr"]:
            gain = 0.75 if image.dtype == np.uint8 else 1.4
            info = np.iinfo(image.dtype)
            image = np.clip(np.rint(image.astype(np.float64) * gain), info.min, info.max).astype(image.dtype)
        volume = os.path.join(folder, f"{name}-{target}-for-preset.nrrd")
        write_nrrd(volume, image, spacing)
        out = os.path.join(folder, f"{name}-{target}-preset-{source}.labels.nrrd")
        subprocess.run([args.volasso, "classify", volume, "--preset", preset, "--out", out] + modality_args(name),
                       check=True, capture_output=True, text=True)
        labels = read_nrrd_labels(out, truth.shape)
        mine = score(truth, labels, class_truth, names, [], lasso_air)[0]
        print(f"{name:<14}{target:>5} preset of seed {source}: {mine:.3f}   own clean loops {own:.3f}", flush=True)
        rows.append((name, source, target, mine, own))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--volasso", default="target/release/volasso")
    parser.add_argument("--seeds", default="101,102,103")
    parser.add_argument("--only", default=None)
    parser.add_argument("--thick", type=int, default=1, help="slices N times as thick (the mean of N along z)")
    parser.add_argument("--classify-args", default="", help="extra arguments for volasso classify")
    parser.add_argument("--forest-cache", default=None,
                        help="keep the forest's labels in this folder and reuse them (keyed by image and strokes)")
    parser.add_argument("--keep", default=None, help="keep volumes, strokes and labels in this folder")
    parser.add_argument("--presets", action="store_true",
                        help="also apply each seed's clean classification as a preset to the next seed's scan")
    parser.add_argument("--hands", default="clean,leaky",
                        help="the fingers, of clean, leaky, offset (off-centre: over one side, short of the other) "
                             "and wide (4 voxels over); each after the ones before it, so adding one leaves "
                             "the others' strokes as they were")
    args = parser.parse_args()
    hands = args.hands.split(",")
    if any(hand not in HANDS for hand in hands):
        parser.error(f"--hands: each of {', '.join(HANDS)}")
    folder = args.keep or tempfile.mkdtemp(prefix="volasso-heldout-")
    os.makedirs(folder, exist_ok=True)
    rows, purity, preset_rows = [], [], []
    print(f"{'case':<14}{'seed':>5} {'hand':<6}{'air':<5}{'volasso':>8}{'forest':>8}{'diff':>8}"
          f"{'air classed':>12}{'lasso kept':>11}   per class (volasso)")
    for name, make in PHANTOMS.items():
        if args.only and name not in args.only.split(","):
            continue
        if name == "mni-t1" and mni_folder() is None:
            print("mni-t1: skipped (pip install nilearn, or set VOLASSO_MNI_DIR to a folder with the "
                  "ICBM 152 2009a files)", flush=True)
            continue
        made_cases = {}
        for seed in [int(s) for s in args.seeds.split(",")]:
            rng = np.random.default_rng(seed * 7919 + len(name))
            made = make(rng)
            image, truth, names, spacing = made[:4]
            drawing = made[4] if len(made) > 4 else truth  # where the finger draws each class
            image, truth, spacing = thick_slices(image, truth, spacing, args.thick)
            if drawing is not truth:
                drawing = thick_slices(made[0], drawing, made[3], args.thick)[1]
            lasso_air = (name not in WITH_AIR or seed % 2 == 0) and name not in DRAWN
            drawn = DRAWN.get(name)
            volume = os.path.join(folder, f"{name}-{seed}.nrrd")
            write_nrrd(volume, image, spacing)
            info = json.loads(subprocess.run([args.volasso, "info", volume, "--json"], check=True,
                                             capture_output=True, text=True).stdout)
            for hand in HANDS[:1 + max(HANDS.index(hand) for hand in hands)]:
                if hand not in hands:
                    draw_strokes(drawing, names, lasso_air, info["top_slices"], hand, rng, drawn)  # the same draws for the rest
                    continue
                strokes, class_truth = draw_strokes(drawing, names, lasso_air, info["top_slices"], hand, rng, drawn)
                stroke_path = os.path.join(folder, f"{name}-{seed}-{hand}.strokes.json")
                with open(stroke_path, "w") as f:
                    json.dump(strokes, f)
                out = os.path.join(folder, f"{name}-{seed}-{hand}.labels.nrrd")
                preset = os.path.join(folder, f"{name}-{seed}.volasso-preset")
                keep_preset = ["--save-preset", preset] if hand == "clean" and args.presets else []
                subprocess.run([args.volasso, "classify", volume, "--strokes", stroke_path, "--out", out]
                               + modality_args(name) + keep_preset + args.classify_args.split(),
                               check=True, capture_output=True, text=True)
                masks = lassoed_voxels(strokes, truth.shape)
                our_labels = read_nrrd_labels(out, truth.shape)
                forest = cached_forest_labels(args.forest_cache, image, strokes, masks, lasso_air)
                if drawn is not None:
                    ours, theirs = (ventricle_purity(truth, labels, class_truth) for labels in (our_labels, forest))
                    print(f"{name:<14}{seed:>5} {hand:<6}ventricle class: CSF {ours[0]:.3f} of it in the brain, "
                          f"grey taken {ours[1]:.3f}, ventricles found {ours[2]:.3f}   (forest: {theirs[0]:.3f}, "
                          f"{theirs[1]:.3f}, {theirs[2]:.3f})", flush=True)
                    purity.append((name, seed, hand) + tuple(ours))
                    continue
                ours = score(truth, our_labels, class_truth, names, masks, lasso_air)
                theirs = score(truth, forest, class_truth, names, masks, lasso_air)
                if hand == "clean" and args.presets:
                    made_cases[seed] = (image, truth, spacing, class_truth, lasso_air, ours[0], preset)
                air = "-" if ours[2] is None else f"{ours[2]:.3f}"
                print(f"{name:<14}{seed:>5} {hand:<6}{'yes' if lasso_air else 'no':<5}{ours[0]:>8.3f}{theirs[0]:>8.3f}"
                      f"{ours[0] - theirs[0]:>+8.3f}{air:>12}{ours[3]:>11.3f}   "
                      + " ".join(f"{d:.2f}" for d in ours[1]), flush=True)
                rows.append((name, seed, hand, ours[0], theirs[0], ours[2], ours[3]))
        preset_rows.extend(apply_presets(args, folder, name, names, made_cases))
    print()
    for hand in hands:
        sel = [r for r in rows if r[2] == hand]
        if sel:
            worst = min(sel, key=lambda r: r[3] - r[4])
            print(f"{hand:<6} volasso {np.mean([r[3] for r in sel]):.3f}  forest {np.mean([r[4] for r in sel]):.3f}"
                  f"  mean diff {np.mean([r[3] - r[4] for r in sel]):+.3f}"
                  f"  worst {worst[3] - worst[4]:+.3f} ({worst[0]} seed {worst[1]})")
    air = [r[5] for r in rows if r[5] is not None]
    if air:
        print(f"air around the body that got a class: worst {max(air):.3f} over {len(air)} runs")
    if rows:
        print(f"lassoed voxels that kept their class: worst {min(r[6] for r in rows):.3f}")
        for hand in hands:
            gaps = [(r[0], r[1], r[3]) for r in rows if r[2] == hand]
            if hand != "clean" and gaps:
                clean = {(r[0], r[1]): r[3] for r in rows if r[2] == "clean"}
                worst = min(gaps, key=lambda g: clean.get(g[:2], 1) - g[2])
                if worst[:2] in clean:
                    print(f"clean minus {hand}: worst {clean[worst[:2]] - worst[2]:+.3f} ({worst[0]} seed {worst[1]})")
    if preset_rows:
        print("\npresets (trained on one seed, applied to the next; macro Dice: preset, own clean loops)")
        for case in dict.fromkeys(r[0] for r in preset_rows):
            sel = [r for r in preset_rows if r[0] == case]
            mine, own = np.mean([r[3] for r in sel]), np.mean([r[4] for r in sel])
            print(f"{case:<18} preset {mine:.3f}  own loops {own:.3f}  difference {mine - own:+.3f}")
    if purity:
        print(f"ventricle class: CSF share of it in the brain worst {min(p[3] for p in purity):.3f}, "
              f"grey matter taken worst {max(p[4] for p in purity):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
