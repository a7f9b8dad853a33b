"""What one core's work costs while the other core works too: a cache-resident probe (64 x 64
matrix products) and a memory-bound one (passes over a 64 MB array), each alone and then as two
processes at once. Prints one JSON line per run.

Run from a checkout: python benchmarks/results/side_by_side_2026-12-06b/probes.py [ROUNDS]
"""

import json
import subprocess
import sys
import time

import numpy as np


def cached() -> None:
    x = np.random.default_rng(0).standard_normal((64, 64))
    for _ in range(400000):
        x @ x


def streaming() -> None:
    a = np.ones(8_000_000)
    b = np.empty_like(a)
    for _ in range(500):
        np.multiply(a, 1.0001, out=b)
        a, b = b, a


def measure(kind: str) -> dict:
    cpu, wall = time.process_time(), time.perf_counter()
    {"cached": cached, "streaming": streaming}[kind]()
    return {"cpu_s": round(time.process_time() - cpu, 3), "wall_s": round(time.perf_counter() - wall, 3)}


def run(kind: str, processes: int) -> list[dict]:
    cmd = [sys.executable, __file__, "--one", kind]
    env = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, env=env) for _ in range(processes)]
    return [json.loads(p.communicate()[0]) for p in procs]


if __name__ == "__main__":
    if sys.argv[1:2] == ["--one"]:
        print(json.dumps(measure(sys.argv[2])))
    else:
        for _ in range(int(sys.argv[1]) if len(sys.argv) > 1 else 3):
            for kind in ("cached", "streaming"):
                for processes in (1, 2):
                    print(json.dumps({"probe": kind, "processes": processes, "runs": run(kind, processes)}))
