"""Fingerprints of a small generation run and a one-fold evaluation (same seed, same bytes).

Runs `vsmp-imu generate` (HAPT12, held-out subject 1, library SMPs, k 2, alpha 0.5) and
`vsmp-imu evaluate` (HAPT12 low-resource 1 %, fold 1, seed 0, RF; real, classical, vsmp,
imugpt) in subprocesses, then hashes what they wrote: the columns of synthetic.parquet
(windows, provenance, verdicts), the SMP files, prompts.jsonl and summary.json, and the
Macro-F1 of every results.json row and the whole results.json (output folder masked). A refactor that must not change results compares
the fingerprints taken before and after it.

Usage:  python benchmarks/fingerprint.py OUT_DIR [--compare BEFORE.json]
Writes OUT_DIR/fingerprint.json; with --compare, prints the differences and exits 1 on any.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq

GENERATE = ["generate", "--dataset", "hapt12", "--holdout", "1", "--source", "library", "--k", "2",
            "--alpha", "0.5", "--workers", "1"]
EVALUATE = ["evaluate", "--dataset", "hapt12", "--protocol", "low-resource", "--budgets", "1",
            "--folds", "1", "--seeds", "1", "--backbones", "rf", "--methods", "real,classical,vsmp,imugpt",
            "--k", "2"]


def _cli(args: list[str]) -> None:
    cmd = [sys.executable, "-c", "from vsmp_imu.cli import main; main()", *args]
    subprocess.run(cmd, check=True)


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def generation_fingerprint(folder: Path) -> dict[str, str]:
    table = pq.read_table(folder / "synthetic.parquet")
    out = {f"column:{name}": _sha(json.dumps(table.column(name).to_pylist()).encode())
           for name in table.column_names}
    out["parquet_metadata"] = _sha(json.dumps({k.decode(): v.decode() for k, v in
                                               table.schema.metadata.items()}, sort_keys=True).encode())
    for path in sorted((folder / "smps").glob("*.json")):
        out.setdefault("smps", "")
        out["smps"] = _sha((out["smps"] + path.name + _sha(path.read_bytes())).encode())
    out["prompts.jsonl"] = _sha((folder / "prompts.jsonl").read_bytes())
    out["summary.json"] = _sha((folder / "summary.json").read_bytes())
    return out


def evaluation_fingerprint(folder: Path) -> dict[str, str]:
    text = (folder / "results.json").read_text()
    results = json.loads(text)
    out = {f"macro_f1:{row['method']}:{row['backbone']}:{row['budget']}": repr(row["macro_f1_mean"])
           for row in results["summary"]}
    # the whole file, but for the output folder the generative methods' cache lies in
    out["results.json"] = _sha(text.replace(str(folder.resolve()), "OUT").replace(str(folder), "OUT").encode())
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--compare", type=Path, default=None)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    _cli([*GENERATE, "-o", str(args.out / "generate")])
    _cli([*EVALUATE, "-o", str(args.out / "evaluate")])
    prints = {"generate": generation_fingerprint(args.out / "generate"),
              "evaluate": evaluation_fingerprint(args.out / "evaluate")}
    (args.out / "fingerprint.json").write_text(json.dumps(prints, indent=2, sort_keys=True) + "\n")
    if args.compare is None:
        return 0
    before = json.loads(args.compare.read_text())
    differ = [f"{part}/{key}" for part in prints for key in sorted(set(prints[part]) | set(before[part]))
              if prints[part].get(key) != before[part].get(key)]
    for key in differ:
        print(f"differs: {key}")
    print(f"{len(differ)} of {sum(len(v) for v in prints.values())} fingerprints differ")
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
