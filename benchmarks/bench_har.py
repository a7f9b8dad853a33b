"""HAR harness benchmarks on HAPT (CPU).

1. HAPT LOPO with RF-ECDF, Real-only, 1 seed, all 30 folds (or the folds
   given): wall time (target <= 5 min for the 30 folds on 2 cores) and the
   Macro-F1 it reaches.
2. One DeepConvLSTM fold (held-out subject 1) with the CPU defaults (AdamW,
   lr 1e-3, batch 1024, early stopping on validation Macro-F1, max 60 epochs,
   patience 10): wall time, epochs run, seconds per epoch.

Usage:  .venv/bin/python benchmarks/bench_har.py [--skip-rf] [--skip-dclstm]
        [--max-epochs N] [--fold S] [--threads N] [--rf-folds 1,2,3]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.evaluate import EvalConfig, Evaluation

RF_TARGET_S = 300.0
HAPT_FOLDS = 30


def bench_rf(threads: int | None, folds: tuple[str, ...] | None = None) -> dict:
    """RF-ECDF LOPO on HAPT; `folds=None` runs all 30. Returns the figures."""
    dataset = load_dataset("hapt")
    dataset.windows()  # load and cache outside the timing
    config = EvalConfig(
        dataset="hapt",
        backbones=("rf",),
        methods=("real",),
        folds=folds,
        backbone_params={"rf": {"n_jobs": threads or -1}},
    )
    start = time.perf_counter()
    results = Evaluation(config, dataset).run()
    wall = time.perf_counter() - start
    (row,) = results.summary
    per_fold = wall / row["n"]
    out = {
        "folds_run": row["n"], "wall_s": wall, "per_fold_s": per_fold,
        "thirty_fold_s": wall if row["n"] == HAPT_FOLDS else per_fold * HAPT_FOLDS,
        "extrapolated": row["n"] != HAPT_FOLDS,
        "macro_f1": row["macro_f1_mean"], "macro_f1_std": row["macro_f1_std"],
        "accuracy": row["accuracy_mean"], "n_jobs": threads or -1,
    }
    how = "extrapolated from " + str(row["n"]) + " folds" if out["extrapolated"] else "measured"
    print(
        f"HAPT LOPO RF-ECDF (Real-only, 1 seed, {row['n']} folds): wall {wall:.1f} s, "
        f"{per_fold:.1f} s per fold; 30 folds {out['thirty_fold_s']:.1f} s ({how}; "
        f"target <= {RF_TARGET_S:.0f} s on 2 cores, ratio {out['thirty_fold_s'] / RF_TARGET_S:.2f})"
    )
    print(
        f"  Macro-F1 {100 * row['macro_f1_mean']:.2f} ± {100 * row['macro_f1_std']:.2f}, "
        f"accuracy {100 * row['accuracy_mean']:.2f} ± {100 * row['accuracy_std']:.2f}, "
        f"n = {row['n']}"
    )
    return out


def bench_dclstm(fold: str, max_epochs: int, threads: int | None, verbose: bool = True) -> dict:
    """One DeepConvLSTM fold; returns wall time, epochs and training throughput."""
    dataset = load_dataset("hapt")
    dataset.windows()
    params = {"max_epochs": max_epochs, "patience": 10, "verbose": verbose}
    if threads:
        params["n_threads"] = threads
    config = EvalConfig(
        dataset="hapt",
        backbones=("dclstm",),
        methods=("real",),
        folds=(fold,),
        backbone_params={"dclstm": params},
    )
    start = time.perf_counter()
    (record,) = Evaluation(config, dataset).run().records
    wall = time.perf_counter() - start
    epochs = record["epochs"]
    print(
        f"DeepConvLSTM, HAPT fold {fold} on CPU: wall {wall:.1f} s, {epochs} epochs "
        f"(best {record['best_epoch']}, limit {max_epochs}, patience 10), "
        f"{wall / max(epochs, 1):.1f} s per epoch, {record['n_train_real']} training and "
        f"{record['n_val']} validation windows"
    )
    print(f"  Macro-F1 {100 * record['macro_f1']:.2f}, accuracy {100 * record['accuracy']:.2f}")
    return {
        "fold": fold, "wall_s": wall, "epochs": epochs, "max_epochs": max_epochs,
        "best_epoch": record["best_epoch"], "per_epoch_s": wall / max(epochs, 1),
        "n_train": record["n_train_real"], "n_val": record["n_val"],
        "train_windows_per_s": record["n_train_real"] * epochs / wall,
        "macro_f1": record["macro_f1"], "threads": threads,
    }


def bench_guard(threads: int | None, protocols: tuple[str, ...] = ("long-tail", "low-resource")) -> dict:
    """What the per-class do-no-harm guard (`--share-selection class`, evaluate's default on the
    long tail with the forests) costs: one HAPT12 fold (held-out subject 1, seed 0) with RF and Classical Aug
    (whose synthetic windows pass through the guard like VSMP-IMU's and cost nothing to make),
    the command line's weights, run without and with the guard in one process; the ratio is
    the guard's price. Low-resource at 5 % (at 1 % no class reaches the guard's floor)."""
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.har.weights import DEFAULT_CLASS_WEIGHT, DEFAULT_SYNTHETIC_WEIGHT
    from vsmp_imu.methods import register_all

    register_all()
    dataset = load_dataset("hapt12")
    dataset.windows()
    out = {}
    for protocol in protocols:
        walls = {}
        for mode in ("off", "class"):
            config = EvalConfig(
                dataset="hapt12", protocol=protocol, budgets=(5.0,) if protocol == "low-resource" else (None,),
                backbones=("rf",), methods=("classical",), folds=("1",), seeds=(0,), alpha=0.5,
                policy="scarcity", share_selection=mode, synthetic_weight=DEFAULT_SYNTHETIC_WEIGHT,
                backbone_params={"rf": {"n_jobs": threads or -1, "class_weight": DEFAULT_CLASS_WEIGHT}})
            start = time.perf_counter()
            Evaluation(config, dataset).run()
            walls[mode] = time.perf_counter() - start
        out[protocol] = {"off_s": walls["off"], "class_s": walls["class"], "ratio": walls["class"] / walls["off"]}
        print(f"HAPT12 {protocol} fold 1, RF + Classical Aug: {walls['off']:.1f} s without the guard, "
              f"{walls['class']:.1f} s with it (x{out[protocol]['ratio']:.2f})")
    return {"protocols": out}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-rf", action="store_true")
    parser.add_argument("--skip-dclstm", action="store_true")
    parser.add_argument("--max-epochs", type=int, default=60)
    parser.add_argument("--fold", default="1")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--rf-folds", default=None, help="comma-separated held-out subjects (default: all 30)")
    args = parser.parse_args()
    print(f"CPU cores available: {len(os.sched_getaffinity(0))}; numpy {np.__version__}")
    if not args.skip_rf:
        bench_rf(args.threads, tuple(args.rf_folds.split(",")) if args.rf_folds else None)
    if not args.skip_dclstm:
        bench_dclstm(args.fold, args.max_epochs, args.threads)


if __name__ == "__main__":
    main()
