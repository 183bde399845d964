#!/usr/bin/env python3
"""scikit-learn's random forest (100 trees) on the accuracy harness's cases, beside volasso.

`volasso accuracy --export DIR --json > volasso.jsonl` writes one folder per case and hand
(`CASE-SEED-HAND/`) with the lassoed voxels' paper features (`train_features.npy`), their class
ids (`train_labels.npy`), the paper features of every voxel (`features.npy`), the truth
(`truth.npy`) and `case.json`. This script trains `RandomForestClassifier(n_estimators=100,
random_state=0)` on the same lassoed voxels and the same 5 features, labels every voxel, and
scores it as the harness does (macro Dice over the truth classes). When the air is lassoed it
is a class like any other; when it is not, voxels below Otsu's threshold are background (a
classifier alone cannot say "background").

With the volasso JSON lines it prints, per hand, the mean macro Dice over tuning (seeds 1-4)
and check cases (seeds 5 and up) of every method beside the forest, and per method the mean
and the worst difference to the forest over the check cases.

Usage: python3 scripts/accuracy_sklearn.py DIR [volasso.jsonl]
"""
import json
import os
import sys

import numpy as np


def dice(truth, predicted, cls):
    t, p = truth == cls, predicted == cls
    total = t.sum() + p.sum()
    return 1.0 if total == 0 else 2.0 * np.logical_and(t, p).sum() / total


def forest_case(folder):
    from sklearn.ensemble import RandomForestClassifier

    case = json.load(open(os.path.join(folder, "case.json")))
    train_x = np.load(os.path.join(folder, "train_features.npy"))
    train_y = np.load(os.path.join(folder, "train_labels.npy"))
    features = np.load(os.path.join(folder, "features.npy"))
    truth = np.load(os.path.join(folder, "truth.npy"))
    forest = RandomForestClassifier(n_estimators=100, random_state=0, n_jobs=-1).fit(train_x, train_y)
    labels = forest.predict(features).astype(np.int64)
    if case["lasso_background"]:
        predicted = labels - 1
    else:
        predicted = np.where(features[:, 0] < case["otsu_threshold"], 0, labels)
    classes = len(case["class_names"])
    return [dice(truth, predicted, c) for c in range(classes)]


def main() -> int:
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    root = sys.argv[1]
    rows = []
    for name in sorted(os.listdir(root)):
        folder = os.path.join(root, name)
        if not os.path.exists(os.path.join(folder, "case.json")):
            continue
        kind, seed, hand = name.rsplit("-", 2)
        per_class = forest_case(folder)
        macro = float(np.mean(per_class))
        role = "tune" if int(seed) <= 4 else "check"
        rows.append({"case": kind, "seed": int(seed), "hand": hand, "role": role, "method": "sklearn-forest",
                     "macro_dice": macro})
        print(f"{kind:<9} {seed:>4} {role:<5} {hand:<5} sklearn-forest    {macro:6.3f}  "
              + " ".join(f"{d:.3f}" for d in per_class), flush=True)
    if len(sys.argv) > 2:
        with open(sys.argv[2]) as f:
            rows += [json.loads(line) for line in f if line.startswith("{")]
    methods = []
    for row in rows:
        if row["method"] not in methods:
            methods.append(row["method"])
    hands = sorted({row["hand"] for row in rows})
    print()
    print(f"{'method':<17}" + "".join(f" {h + ' tune':>12} {h + ' check':>12}" for h in hands))
    for method in methods:
        line = f"{method:<17}"
        for hand in hands:
            for role in ["tune", "check"]:
                values = [r["macro_dice"] for r in rows if r["method"] == method and r["hand"] == hand and r["role"] == role]
                line += f" {np.mean(values):>12.3f}" if values else f" {'-':>12}"
        print(line)
    forest = {(r["case"], r["seed"], r["hand"]): r["macro_dice"] for r in rows if r["method"] == "sklearn-forest"}
    print()
    print("difference to sklearn-forest over the check cases (mean, worst case):")
    for method in methods:
        if method == "sklearn-forest":
            continue
        for hand in hands:
            deltas = [(r["macro_dice"] - forest[(r["case"], r["seed"], r["hand"])], r["case"], r["seed"]) for r in rows
                      if r["method"] == method and r["hand"] == hand and r["role"] == "check"
                      and (r["case"], r["seed"], r["hand"]) in forest]
            if deltas:
                worst = min(deltas)
                print(f"  {method:<17} {hand:<5} mean {np.mean([d[0] for d in deltas]):+.3f}  "
                      f"worst {worst[0]:+.3f} ({worst[1]} seed {worst[2]})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
