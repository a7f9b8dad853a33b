"""The fold series of folds.json: N whole benchmark folds with W local workers, wall and CPU-seconds.

Run from a checkout: PYTHONPATH=src python benchmarks/results/side_by_side_2026-12-06b/folds.py W N
(it prints one JSON list of [wall_s, cpu_s] per fold).
"""

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # benchmarks/, for run_all

import run_all  # noqa: E402

from vsmp_imu.executor import LocalExecutor  # noqa: E402


def main(workers: int, folds: int) -> None:
    run_all.one_thread()
    out = []
    for _ in range(folds):
        executor = run_all._started(lambda n: LocalExecutor(n, show_progress=False), workers)
        cpu = run_all._process_cpu_s()
        fig = run_all.run_fold(executor, 0.2)
        spent = run_all._cpu_delta(cpu, run_all._process_cpu_s())
        out.append((round(fig["wall_s"], 2), round(sum(spent.values()), 2)))
    print(json.dumps(out))


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]))
