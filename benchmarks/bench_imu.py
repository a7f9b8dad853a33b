"""Benchmark of the imu room.

Prints (medians over many runs, one process, one core):
- time to simulate one 50 Hz sensor from a 10 s, 30 fps SMPL-22 motion (ms);
- the same split into the two steps (kinematics once, readings for one candidate);
- `sensor_readings` for 64 calibration candidates on 10 s (ms), and the ratio
  of a Python loop over the 64 candidates to the vectorized call.

Targets: simulation <= 10 ms per sensor.
Run: .venv/bin/python benchmarks/bench_imu.py
"""

from __future__ import annotations

import os
import statistics
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from vsmp_imu.imu import (  # noqa: E402
    ImuSimulator,
    VirtualSensor,
    draw_noise,
    sensor_readings,
    simulate_kinematics,
)
from vsmp_imu.motion import Motion, forward_kinematics, smpl22_skeleton  # noqa: E402

FPS, DURATION_S, FS_HZ, N_CANDIDATES = 30.0, 10.0, 50.0, 64


def benchmark_motion(seed: int = 0) -> Motion:
    """A 10 s, 30 fps SMPL-22 motion: every joint turns smoothly, the root walks."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(DURATION_S * FPS) + 1) / FPS
    freq = rng.uniform(0.3, 2.0, (22, 3))
    amp = rng.uniform(0.0, 0.5, (22, 3))
    phase = rng.uniform(0, 2 * np.pi, (22, 3))
    rotvec = amp * np.sin(2 * np.pi * freq * t[:, None, None] + phase)
    local = Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_quat().reshape(len(t), 22, 4)
    skeleton = smpl22_skeleton()
    root = np.stack([0.1 * np.sin(t), skeleton.pelvis_height() + 0.03 * np.cos(4 * t), 1.2 * t], 1)
    pos, rot = forward_kinematics(skeleton, local, root)
    return Motion(pos, rot, FPS, meta={"source": "benchmark"})


def median_ms(fn, repeats: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def main() -> dict[str, float]:
    motion = benchmark_motion()
    sim = ImuSimulator(FS_HZ, seed=0)
    sensor = VirtualSensor.at("right_wrist")
    kin = simulate_kinematics(motion, sensor, FS_HZ)
    noise = draw_noise(sensor, kin.n_samples, FS_HZ, 0, sensor.name)
    rng = np.random.default_rng(1)
    mounts = Rotation.from_euler("xyz", rng.uniform(-10, 10, (N_CANDIDATES, 3)), degrees=True).as_matrix()
    b_a = rng.uniform(-0.5, 0.5, (N_CANDIDATES, 3))
    b_w = rng.uniform(-0.05, 0.05, (N_CANDIDATES, 3))
    k_a = rng.uniform(0.5, 2.0, N_CANDIDATES)
    k_w = rng.uniform(0.5, 2.0, N_CANDIDATES)
    grav = rng.random(N_CANDIDATES) < 0.5

    def loop():
        for i in range(N_CANDIDATES):
            sensor_readings(kin, mounts[i], b_a[i], b_w[i], k_a[i], k_w[i], bool(grav[i]), noise)

    results = {
        "simulate_one_sensor_ms": median_ms(lambda: sim.simulate(motion, sensor), 200),
        "kinematics_ms": median_ms(lambda: simulate_kinematics(motion, sensor, FS_HZ), 200),
        "readings_one_candidate_ms": median_ms(lambda: sensor_readings(kin, noise=noise), 200),
        "readings_64_vectorized_ms": median_ms(
            lambda: sensor_readings(kin, mounts, b_a, b_w, k_a, k_w, grav, noise), 200),
        "readings_64_python_loop_ms": median_ms(loop, 30),
    }
    results["loop_over_vectorized_ratio"] = (results["readings_64_python_loop_ms"]
                                             / results["readings_64_vectorized_ms"])
    print(f"imu benchmark: {DURATION_S:g} s SMPL-22 motion at {FPS:g} fps -> {FS_HZ:g} Hz "
          f"({kin.n_samples} samples), {N_CANDIDATES} candidates")
    for key, value in results.items():
        unit = "x" if key.endswith("ratio") else "ms"
        print(f"  {key:32s} {value:8.3f} {unit}")
    print(f"  target simulate <= 10 ms: {'met' if results['simulate_one_sensor_ms'] <= 10 else 'NOT met'}")
    return results


if __name__ == "__main__":
    main()
