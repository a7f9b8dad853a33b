"""The activity folders under examples/: each overrides library activities of the same name."""

from __future__ import annotations

from pathlib import Path

import pytest

from vsmp_imu.pipeline.check import movement_s, simulate_signal
from vsmp_imu.pipeline.sample import backend_for
from vsmp_imu.smp.library import ActivityLibrary

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TIMED = EXAMPLES / "hapt12_timed"
# how much longer each timed file's execution moves than the library's (what data check measured)
SLOWER = {"stand_to_sit": 1.4, "sit_to_lie": 1.7, "lie_to_sit": 1.4}


@pytest.mark.parametrize("name", sorted(SLOWER))
def test_each_timed_execution_moves_as_much_longer_as_intended(name):
    from vsmp_imu.har.datasets.hapt import WAIST

    seconds = {}
    for key, dirs in (("plain", ()), ("timed", (str(TIMED),))):
        backend = backend_for("procedural", dirs)
        library = ActivityLibrary.load([Path(d) for d in dirs])
        runs = [movement_s(simulate_signal(backend.generate(library.get(name).smp, seed), WAIST, 50.0)[0], 50.0)
                for seed in range(3)]
        seconds[key] = sum(runs) / len(runs)
    assert abs(seconds["timed"] / seconds["plain"] / SLOWER[name] - 1) < 0.12


PELVIS = EXAMPLES / "hapt12_pelvis"
# the waist's fastest rotation in one execution, rad/s: the library's file, the example's (data check
# measured 0.80 and 0.89 for the library's, 1.61 and 1.41 for HAPT12's subjects)
PEAK_TURN = {"sit_to_stand": (0.95, 1.35), "stand_to_sit": (0.95, 1.15)}


@pytest.mark.parametrize(("folder", "names"), [(TIMED, SLOWER), (PELVIS, PEAK_TURN)], ids=["timed", "pelvis"])
def test_an_example_folder_overrides_the_library_with_its_smps(folder, names):
    plain, example = ActivityLibrary.load(), ActivityLibrary.load([folder])
    assert sorted(p.stem for p in folder.glob("*.yaml")) == sorted(names)
    for name in names:
        assert example.get(name).path.parent == folder and plain.get(name).path.parent != folder
        assert example.get(name).smp == plain.get(name).smp  # only the recipe differs


@pytest.mark.parametrize("name", sorted(PEAK_TURN))
def test_a_pelvis_over_the_feet_turns_the_waist_faster(name):
    from vsmp_imu.har.datasets.hapt import WAIST
    from vsmp_imu.pipeline.check import peak_turn_rad_s

    below, above = PEAK_TURN[name]
    for dirs, ok in (((), lambda v: v < below), ((str(PELVIS),), lambda v: v > above)):
        backend = backend_for("procedural", dirs)
        library = ActivityLibrary.load([Path(d) for d in dirs])
        for seed in range(3):
            peak = peak_turn_rad_s(simulate_signal(backend.generate(library.get(name).smp, seed), WAIST, 50.0)[0], 50.0)
            assert ok(peak), (name, dirs, seed, peak)
