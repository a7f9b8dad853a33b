"""Motion compiled from the SMP: every library activity without its recipe, SMP-only activities, controls."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion import get_backend, measure
from vsmp_imu.motion.compiler import compile_recipe, compile_recipe_data
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.motion.selfcheck import is_plausible, plausibility
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.library import ActivityLibrary

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "compiled_activities"
TOP_K = 3  # a named (joint, plane) must be among the motion's 3 largest angular ranges


@pytest.fixture(scope="module")
def bare_library(library) -> ActivityLibrary:
    """The built-in library with every `procedural:` recipe removed."""
    return ActivityLibrary([dataclasses.replace(e, extras={}) for e in library])


@pytest.fixture(scope="module")
def tests_library() -> ActivityLibrary:
    return ActivityLibrary.load([FIXTURES])


@pytest.fixture(scope="module")
def compiled(tests_library) -> ProceduralBackend:
    return ProceduralBackend(tests_library)


def _names() -> list[str]:
    return ActivityLibrary.load().names()


@pytest.mark.parametrize("name", _names())
def test_every_library_activity_compiles_without_its_recipe(bare_library, name):
    entry = bare_library.get(name)
    assert "procedural" not in entry.extras
    motion = ProceduralBackend(bare_library).generate(entry.smp, seed=0)
    assert motion.meta["motion_source"] == "compiled" and motion.meta["activity"] == name
    assert is_plausible(motion), plausibility(motion)
    assert motion.meta["principal_joints"]
    hard = intervene(intervene(entry.smp, "tempo", "fast"), "amplitude", "large")
    fast_large = ProceduralBackend(bare_library).generate(hard, seed=1)
    assert is_plausible(fast_large), plausibility(fast_large)


def test_compiled_motions_move_the_joints_the_recipes_move(library):
    """The recipe motion's largest (joint, plane) is among the compiled motion's three largest."""
    recipe, always = ProceduralBackend(library), ProceduralBackend(library, compile_mode="always")
    agree = []
    for entry in library:
        top = measure.ranked_joint_planes(recipe.generate(entry.smp, seed=0))[0][0]
        ranked = [k for k, _ in measure.ranked_joint_planes(always.generate(entry.smp, seed=0))]
        agree.append(top in ranked[:TOP_K])
    assert np.mean(agree) >= 0.8


def test_recipes_stay_the_default_and_compiled_is_an_option(library):
    smp = library.get("bicep_curls").smp
    default = ProceduralBackend(library).generate(smp, seed=4)
    recipe_only = ProceduralBackend(library, compile_mode="recipe").generate(smp, seed=4)
    assert default.to_npz_bytes() == recipe_only.to_npz_bytes()
    assert "motion_source" not in default.meta
    compiled = get_backend("compiled", library=library).generate(smp, seed=4)
    assert compiled.meta["motion_source"] == "compiled"
    assert not np.allclose(compiled.positions[: default.n_frames], default.positions[: compiled.n_frames])


def test_bad_compile_mode():
    with pytest.raises(ValidationError, match="compile_mode"):
        ProceduralBackend(compile_mode="sometimes")


def test_same_seed_same_bytes(compiled, tests_library):
    smp = tests_library.get("golf_swing").smp
    assert compiled.generate(smp, seed=3).to_npz_bytes() == compiled.generate(smp, seed=3).to_npz_bytes()
    assert compiled.generate(smp, seed=3).to_npz_bytes() != compiled.generate(smp, seed=4).to_npz_bytes()


@pytest.mark.parametrize("path", sorted(FIXTURES.glob("*.yaml")), ids=lambda p: p.stem)
def test_smp_only_activities_move_the_joints_and_planes_they_name(compiled, tests_library, path):
    entry = tests_library.get(path.stem)
    assert "procedural" not in entry.extras and entry.name not in ActivityLibrary.load()
    motion = compiled.generate(entry.smp, seed=0)
    ranked = [k for k, _ in measure.ranked_joint_planes(motion)]
    for joint, plane in entry.extras["expected_planes"]:
        assert (joint, plane) in ranked[:TOP_K], (joint, plane, ranked[:5])


def test_at_least_ten_test_activities():
    assert len(list(FIXTURES.glob("*.yaml"))) >= 10


def test_smp_only_activity_file_synthesizes_through_the_cli(cli, tmp_path):
    folder = tmp_path / "my_activities"
    folder.mkdir()
    shutil.copy(FIXTURES / "hammer_curl_kettlebell.yaml", folder)
    out = tmp_path / "hammer.npz"
    code, stdout, err = cli("motion", "synth", "hammer curl with a kettlebell", "--library", folder,
                            "--seed", "1", "-o", out)
    assert code == 0, err
    motion = Motion.load(out)
    assert motion.meta["motion_source"] == "compiled" and motion.meta["activity"] == "hammer_curl_kettlebell"
    assert measure.ranked_joint_planes(motion)[0][0] == ("elbow", "sagittal")
    assert motion.meta["controls"]["repetitions"] == 10


def test_an_activity_file_given_as_the_smp_synthesizes_its_activity(cli, tmp_path):
    out = tmp_path / "hammer.npz"
    code, _, err = cli("motion", "synth", FIXTURES / "hammer_curl_kettlebell.yaml", "--seed", "1", "-o", out)
    assert code == 0, err
    motion = Motion.load(out)
    assert motion.meta["motion_source"] == "compiled" and motion.meta["activity"] == "hammer_curl_kettlebell"
    assert measure.ranked_joint_planes(motion)[0][0] == ("elbow", "sagittal")


def test_an_activity_file_with_a_recipe_is_performed_by_its_recipe(cli, tmp_path, library):
    """A user's copy of a library file, its recipe edited: the file's recipe performs it, not the library's."""
    data = yaml.safe_load(library.get("jumping_jacks").path.read_text())
    data["procedural"]["poses"]["open"] = {"shoulder_flex": 140, "hip_abd": 14}  # the arms rise forward
    path = tmp_path / "jumping_jacks.yaml"
    path.write_text(yaml.safe_dump(data))
    code, _, err = cli("motion", "synth", path, "--seed", "0", "-o", tmp_path / "m.npz")
    assert code == 0, err
    mine = Motion.load(tmp_path / "m.npz")
    assert "motion_source" not in mine.meta  # a recipe motion
    assert measure.ranked_joint_planes(mine)[0][0] == ("shoulder", "sagittal")
    code, _, err = cli("motion", "synth", "jumping_jacks", "--seed", "0", "-o", tmp_path / "lib.npz")
    assert code == 0, err
    assert measure.ranked_joint_planes(Motion.load(tmp_path / "lib.npz"))[0][0] == ("shoulder", "frontal")


def test_an_activity_file_is_validated_whole_and_its_errors_name_it(cli, tmp_path):
    code, stdout, err = cli("smp", "validate", FIXTURES / "bicycle_crunch.yaml")
    assert code == 0, err
    assert "valid" in stdout and "bicycle crunch" in stdout
    data = yaml.safe_load((FIXTURES / "bicycle_crunch.yaml").read_text())
    data["captions"] = "not a list"
    path = tmp_path / "bicycle_crunch.yaml"
    path.write_text(yaml.safe_dump(data))
    code, _, err = cli("motion", "synth", path, "--seed", "0", "-o", tmp_path / "m.npz")
    assert code == 2
    assert "bicycle_crunch.yaml" in err and "captions" in err
    assert not (tmp_path / "m.npz").exists()


def test_a_label_that_only_resembles_a_library_activity_gets_no_other_recipe(library):
    """A copy of the bicep-curl SMP labelled 'hammer curl with a kettlebell' (fuzzily 'baseball_swing')."""
    smp = library.get("bicep_curls").smp.model_copy(deep=True)
    smp.activity_label = "hammer curl with a kettlebell"
    motion = ProceduralBackend(library).generate(smp, seed=0)
    assert motion.meta["motion_source"] == "compiled"
    assert motion.meta["activity"] == "hammer_curl_with_a_kettlebell"
    assert measure.ranked_joint_planes(motion)[0][0] == ("elbow", "sagittal")


# -- the SMP's controls, realized by the compiled motion ---------------------------------------
def test_repetitions_tempo_and_amplitude(compiled, tests_library):
    smp = tests_library.get("hammer_curl_kettlebell").smp
    elbows = ["left_elbow", "right_elbow", "left_wrist", "right_wrist"]
    for count in (3, 6):
        motion = compiled.generate(intervene(smp, "repetitions", count), seed=0)
        assert measure.count_repetitions(motion, elbows).count == count
    slow = compiled.generate(intervene(smp, "tempo", "slow"), seed=0)
    fast = compiled.generate(intervene(smp, "tempo", "fast"), seed=0)
    assert fast.duration_s < slow.duration_s
    small = measure.range_of_motion(compiled.generate(intervene(smp, "amplitude", "small"), seed=0), elbows)
    large = measure.range_of_motion(compiled.generate(intervene(smp, "amplitude", "large"), seed=0), elbows)
    assert large > small * 1.3


def test_relative_durations_set_the_phases(compiled, tests_library):
    smp = tests_library.get("hammer_curl_kettlebell").smp
    longer = smp.model_copy(deep=True)
    longer.primitive_durations.values = [0.7, 0.3]
    phases = {}
    for name, s in (("default", smp), ("longer", longer)):
        first = [p for p in compiled.generate(s, seed=0).meta["phases"] if p["primitive"] == "curl_up"][0]
        phases[name] = first["end_s"] - first["start_s"]
    assert phases["longer"] > 1.3 * phases["default"]


def test_dominant_side_and_symmetry(compiled, tests_library):
    jab = tests_library.get("right_jab").smp
    right = compiled.generate(jab, seed=0)
    lefty = jab.model_copy(deep=True)
    lefty.execution_attributes.dominant_side = "left"
    left = compiled.generate(lefty, seed=0)
    ranges = {side: {m: measure.range_of_motion(mo, [f"{m}_elbow"]) for m in ("left", "right")}
              for side, mo in (("right", right), ("left", left))}
    assert ranges["right"]["right"] > 3 * ranges["right"]["left"]
    assert ranges["left"]["left"] > 3 * ranges["left"]["right"]
    curl = tests_library.get("hammer_curl_kettlebell").smp
    joints = ["left_elbow", "right_elbow", "left_wrist", "right_wrist"]
    sym = measure.symmetry_score(compiled.generate(curl, seed=0), joints)
    asym = measure.symmetry_score(compiled.generate(intervene(curl, "symmetry", "asymmetric"), seed=0), joints)
    assert sym > measure.SYMMETRY_THRESHOLD > asym


def test_displacement_travels(compiled, tests_library):
    smp = tests_library.get("front_raise").smp
    still = compiled.generate(smp, seed=0)
    moved = smp.model_copy(deep=True)
    moved.execution_attributes.global_displacement = "small"
    travel = compiled.generate(moved, seed=0)
    pelvis = still.joint_index("pelvis")
    assert abs(np.ptp(still.positions[:, pelvis, 2])) < 0.1
    assert np.ptp(travel.positions[:, pelvis, 2]) > 0.7


def test_locomotion_and_posture_changes(library):
    bare = ActivityLibrary([dataclasses.replace(e, extras={}) for e in library])
    backend = ProceduralBackend(bare)
    walk = backend.generate(bare.get("walking").smp, seed=0)
    assert np.ptp(walk.positions[:, walk.joint_index("pelvis"), 2]) > 5.0  # about 1.3 m/s for 10 s
    upstairs = backend.generate(bare.get("walking_upstairs").smp, seed=0)
    assert upstairs.positions[-1, 0, 1] - upstairs.positions[0, 0, 1] > 1.0
    sit = backend.generate(bare.get("stand_to_sit").smp, seed=0)
    pelvis_y = sit.positions[:, sit.joint_index("pelvis"), 1]
    assert pelvis_y[0] - pelvis_y[-1] > 0.3
    lie = backend.generate(bare.get("sit_to_lie").smp, seed=0)
    spine = lie.positions[-1, lie.joint_index("spine3")] - lie.positions[-1, lie.joint_index("pelvis")]
    assert abs(spine[1]) < 0.5 * np.linalg.norm(spine)  # the trunk ends horizontal


def test_compiled_recipes_are_cached_by_content(tests_library):
    smp = tests_library.get("front_raise").smp
    assert compile_recipe(smp) is compile_recipe(smp.model_copy(deep=True))


@pytest.mark.slow
def test_compiled_backend_runs_a_hapt12_fold(library):
    """`--backend compiled` through Algorithm 1 on real HAPT data (the compiled-vs-recipe comparison's path)."""
    from vsmp_imu.executor import LocalExecutor
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.har.synthetic import synthetic_budget
    from vsmp_imu.pipeline.fold import FoldGenerator
    from vsmp_imu.pipeline.sources import LibrarySmpSource
    from vsmp_imu.pipeline.spec import GenerationSpec

    ds = load_dataset("hapt12")
    train = ds.windows().where_subjects(["2", "3", "4", "5"])
    budget = synthetic_budget(train.class_counts(), 0.05)
    sources = LibrarySmpSource(library).smps("hapt12", ds.info.label_names)
    gen = FoldGenerator(GenerationSpec(backend="compiled", k=2, oversample=1.5, max_rounds=2),
                        LocalExecutor(1, show_progress=False), None, library=library)
    out = gen.generate(ds.info, train, sources, budget, seed=0, fold="test")
    assert len(out.windows) > 0
    made = [r.provenance for r in out.records if not r.provenance.failed]
    assert made and all(p.backend == "compiled" for p in made)



@pytest.mark.parametrize("name", ["bicep_curl", "jumping_jacks", "sit_to_stand"])
def test_a_sequence_name_spelled_otherwise_compiles_as_its_primitive(library, name):
    """'Curl Up' in primitive_sequence names the primitive curl_up (validation matches case,
    spaces, '_' and '-' aside); the compiler looked it up by its exact name and lost the
    primitive's body parts and description, so it compiled another movement."""
    smp = library.get(name).smp
    spelled = smp.model_copy(update={"primitive_sequence": [n.replace("_", " ").title()
                                                            for n in smp.primitive_sequence]})
    plain, other = compile_recipe_data(smp), compile_recipe_data(spelled)
    assert list(other["primitives"]) != list(plain["primitives"])  # named as the sequence spells them
    assert list(other["primitives"].values()) == list(plain["primitives"].values())
    assert {k: v for k, v in other.items() if k not in ("primitives", "cycle")} == \
        {k: v for k, v in plain.items() if k not in ("primitives", "cycle")}
    assert spelled.raw_durations() == smp.raw_durations()
