#!/usr/bin/env python3
"""Compare volasso's classifier with scikit-learn on the same voxels (speed and labels).

`volasso classify VOLUME --strokes S.json --out L.nrrd --export-features DIR` writes, into DIR:
  train_features.npy   float32 (n, d)  standardised training feature vectors (after the cap)
  train_labels.npy     uint8   (n,)    their class ids
  predict_features.npy float32 (m, d)  standardised features of every voxel volasso classified
                                       (everything above the background threshold)
  volasso_labels.npy   uint8   (m,)    volasso's labels for those voxels
  volasso.json         the classify JSON line (timings, parameters)

This script trains scikit-learn's SVC (LIBSVM, RBF, the same gamma and C, one-vs-one) on the
same training vectors, predicts the same voxels, and prints one JSON line with both timings,
their ratio and the label agreement. With --forest it also times a 100-tree random forest and
reports its agreement with volasso's labels (run volasso with `--classifier forest` to compare
the two forests).

Usage: python3 scripts/compare_sklearn.py DIR [--forest] [--max-voxels N]
"""
import argparse
import json
import sys
import time

import numpy as np


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder")
    parser.add_argument("--forest", action="store_true", help="also time a random forest (100 trees)")
    parser.add_argument("--max-voxels", type=int, default=0,
                        help="predict only this many voxels (evenly spaced) and extrapolate the time; 0 = all")
    args = parser.parse_args()

    folder = args.folder.rstrip("/")
    train_x = np.load(f"{folder}/train_features.npy").astype(np.float64)
    train_y = np.load(f"{folder}/train_labels.npy")
    predict_x = np.load(f"{folder}/predict_features.npy")
    volasso_y = np.load(f"{folder}/volasso_labels.npy")
    with open(f"{folder}/volasso.json") as f:
        volasso = json.load(f)

    from sklearn.svm import SVC

    gamma = volasso["parameters"]["kernel_width"]
    c = volasso["parameters"]["c"]
    m = len(predict_x)
    subset = np.arange(m)
    if args.max_voxels and m > args.max_voxels:
        subset = np.linspace(0, m - 1, args.max_voxels).astype(np.int64)
    scale = m / len(subset)

    started = time.perf_counter()
    svc = SVC(kernel="rbf", gamma=gamma, C=c, decision_function_shape="ovo", cache_size=500)
    svc.fit(train_x, train_y)
    train_seconds = time.perf_counter() - started
    started = time.perf_counter()
    svc_y = svc.predict(predict_x[subset].astype(np.float64))
    predict_seconds = (time.perf_counter() - started) * scale
    result = {
        "voxels_predicted": int(m),
        "voxels_timed": int(len(subset)),
        "training_voxels": int(len(train_y)),
        "volasso_seconds": volasso["seconds"],
        "svc_seconds": {"train": train_seconds, "predict": predict_seconds, "total": train_seconds + predict_seconds},
        "svc_over_volasso_train_predict": (train_seconds + predict_seconds)
        / max(volasso["seconds"]["train"] + volasso["seconds"]["predict"] + volasso["seconds"]["features"], 1e-9),
        "label_agreement_with_svc": float(np.mean(svc_y == volasso_y[subset])),
        "svc_support_vectors": int(svc.n_support_.sum()),
    }
    if args.forest:
        from sklearn.ensemble import RandomForestClassifier

        started = time.perf_counter()
        forest = RandomForestClassifier(n_estimators=100, random_state=0, n_jobs=-1).fit(train_x, train_y)
        forest_train = time.perf_counter() - started
        started = time.perf_counter()
        forest_y = forest.predict(predict_x[subset])
        result["forest_seconds"] = {"train": forest_train, "predict": (time.perf_counter() - started) * scale}
        result["label_agreement_forest_svc"] = float(np.mean(forest_y == svc_y))
        # With `--classifier forest` (or the default) this checks volasso's own forest against
        # scikit-learn's on the same lassos and voxels.
        result["label_agreement_forest_volasso"] = float(np.mean(forest_y == volasso_y[subset]))
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
