"""One generation spec: its fields drive the commands and reach every method unchanged.

Adding a generation option touches the spec (`pipeline/spec.py`), the command line and the
stage that reads it, nothing else: the tests below fail until a new spec field is either an
option of the commands or named here as fixed at the paper's value, and they show that a
pipeline field reaches the methods of an evaluation without any registry edit.
"""

from __future__ import annotations

from dataclasses import fields, replace

import pytest
import typer

from vsmp_imu.cli import app
from vsmp_imu.errors import ConfigError
from vsmp_imu.methods import REGISTRY, make, method_params
from vsmp_imu.pipeline.spec import INTENSITY, PIPELINE_FIELDS, GenerationSpec

# spec field -> option of `vsmp-imu generate`
GENERATE_OPTIONS = {
    "source": "--source", "alpha": "--alpha", "policy": "--policy", "k": "--k", "backend": "--backend",
    "refine": "--no-refine", "uncertainty_conditioned": "--no-uncertainty", "sim_in_the_loop": "--no-sim-loop",
    "rank_grounding": "--no-rank", "per_class_rank": "--per-class-rank", "quality_filter": "--no-filter",
    "motion_fit": "--motion-fit", "gravity_norm": "--gravity-norm", "refill": "--refill", "library_dirs": "--library",
    "side_evidence": "--side-evidence", "texture": "--texture", "window_levels": "--window-levels", "level_parts": "--level-parts", "posture_levels": "--posture-levels",
    "pooled_calibration": "--pooled-calibration",
    "nominal_unseen_postures": "--nominal-unseen-postures", "k_unseen": "--k-unseen",
    "unseen_intensity": "--unseen-intensity", "seen_intensity": "--seen-intensity", "event_durations": "--event-durations", "cadence": "--cadence",
    "executor": "--executor",
    "workers": "--workers",
    "address": "--address", "cache_dir": "--cache-dir", "gpus_per_task": "--gpus-per-task",
}
# spec field -> option of `vsmp-imu evaluate`
EVALUATE_OPTIONS = {
    "source": "--source", "alpha": "--alpha", "policy": "--policy", "k": "--k", "backend": "--backend",
    "per_class_rank": "--per-class-rank", "motion_fit": "--motion-fit", "gravity_norm": "--gravity-norm",
    "side_evidence": "--side-evidence", "texture": "--texture", "window_levels": "--window-levels", "level_parts": "--level-parts", "posture_levels": "--posture-levels",
    "pooled_calibration": "--pooled-calibration",
    "nominal_unseen_postures": "--nominal-unseen-postures", "k_unseen": "--k-unseen",
    "unseen_intensity": "--unseen-intensity", "seen_intensity": "--seen-intensity", "event_durations": "--event-durations", "cadence": "--cadence",
    "refill": "--refill",
    "library_dirs": "--library",
    "executor": "--executor", "workers": "--workers", "address": "--address",
}
# fields the commands leave at the paper's values (the studies and the Python API set them)
NOT_OPTIONS = {"clips", "estimate_mounting", "min_validator_windows", "class_filter", "redundancy_filter",
               "noise", "oversample", "max_rounds", "hop_fraction", "val_fraction", "duration_s"}


def _options(command: str) -> set[str]:
    click_app = typer.main.get_command(app)
    return {opt for p in click_app.commands[command].params for opt in p.opts}


def test_every_spec_field_is_an_option_or_named_as_fixed():
    names = {f.name for f in fields(GenerationSpec)}
    assert set(GENERATE_OPTIONS) | NOT_OPTIONS == names
    assert not set(GENERATE_OPTIONS) & NOT_OPTIONS
    assert set(GENERATE_OPTIONS.values()) <= _options("generate")
    assert set(EVALUATE_OPTIONS.values()) <= _options("evaluate")


@pytest.mark.parametrize("command", ["generate", "evaluate"])
def test_the_variant_counts_default_to_the_spec(command):
    click_app = typer.main.get_command(app)
    defaults = {p.name: p.default for p in click_app.commands[command].params}
    assert (defaults["k"], defaults["k_unseen"]) == (GenerationSpec().k, GenerationSpec().k_unseen) == (16, 16)


@pytest.mark.parametrize("name", ["noise", "hop_fraction", "refill"])
def test_a_pipeline_field_reaches_the_methods_without_registry_edits(name):
    value = {"noise": False, "hop_fraction": 0.25, "refill": 2}[name]
    spec = replace(GenerationSpec(), **{name: value})
    params = method_params(("real", "classical", "vsmp", "vsmp-no-filter", "imugpt"), spec)
    assert set(params) == {"vsmp", "vsmp-no-filter", "imugpt"}  # only the generative ones
    for method, p in params.items():
        fixed = name in REGISTRY[method].switches
        assert (p.get(name) == value) != fixed, (method, p)
        built = make(method, **p).spec
        assert getattr(built, name) == (REGISTRY[method].switches[name] if fixed else value)


def test_method_params_keep_the_recorded_shape():
    """The parameters an evaluation records for its methods (their settings digest) are those
    of the earlier per-method dicts: the options, the variant name or the baselines' k = 1."""
    spec = GenerationSpec(cache_dir="c")
    options = {"source": "library", "k": 16, "backend": "procedural", "per_class_rank": True, "library_dirs": (),
               "workers": 1, "executor": "local", "address": None, "cache_dir": "c"}
    assert REGISTRY["vsmp-class-rank"].params(spec) == {**options, "variant": "vsmp-class-rank"}
    # a variant's switch is what its records say, not the spec's value
    assert REGISTRY["vsmp-pooled-rank"].params(spec) == {**options, "per_class_rank": False,
                                                         "variant": "vsmp-pooled-rank"}
    assert REGISTRY["imugpt"].params(spec) == {**options, "k": 1}
    assert REGISTRY["imutube"].params(replace(spec, clips="clips")) == {**options, "k": 1, "source": "video:clips"}
    assert REGISTRY["classical"].params(spec) == {}


def test_variants_are_replacements_of_the_spec():
    spec = GenerationSpec(k=2, workers=3)
    built = make("vsmp-no-adaptation", spec).spec
    assert built == replace(spec, sim_in_the_loop=False, rank_grounding=False)
    assert built.pipeline_dict().keys() == set(PIPELINE_FIELDS)
    assert {m.kind for m in REGISTRY.values()} == {"real", "augmentation", "baseline", "vsmp"}
    assert [m.name for m in REGISTRY.values() if m.needs_videos] == ["imutube"]


def test_bad_values_are_config_errors_naming_the_field():
    for bad, name in ((dict(k=0), "k"), (dict(workers=0), "workers"), (dict(executor="slurm"), "executor"),
                      (dict(refill=-1), "refill"), (dict(hop_fraction=0.0), "hop_fraction")):
        with pytest.raises(ConfigError) as err:
            GenerationSpec(**bad)
        assert err.value.field == name


# the grounding options given away from their defaults -> the spec fields they set
GROUNDING_ARGS = ("--pooled-rank", "--gravity-norm", "--motion-fit", "--no-texture", "--no-window-levels",
                  "--level-parts", "4", "--posture-levels", "--no-pooled-calibration", "--calibrate-unseen-postures",
                  "--unseen-intensity", "0.5,1.5", "--seen-intensity", "--event-durations", "--no-cadence",
                  "--no-side-evidence")
GROUNDING_FIELDS = {"per_class_rank": False, "gravity_norm": True, "motion_fit": True, "texture": False,
                    "window_levels": False, "level_parts": 4, "posture_levels": True, "pooled_calibration": False,
                    "nominal_unseen_postures": False, "unseen_intensity": (0.5, 1.5), "seen_intensity": True,
                    "event_durations": True, "cadence": False, "side_evidence": False}


@pytest.mark.parametrize("command, planner", [("generate", "plan_fold"), ("evaluate", "evaluation")])
def test_the_grounding_options_reach_the_spec(monkeypatch, tmp_path, command, planner):
    """`generate` and `evaluate` share the grounding options (cli.common.grounding_options):
    each value, given or left at its default, reaches the command's GenerationSpec."""
    from typer.testing import CliRunner

    seen = []

    def plan(spec, request):
        seen.append(spec)
        raise ConfigError("stop")

    monkeypatch.setattr(f"vsmp_imu.app.{planner}", plan)
    where = ("--holdout", "1") if command == "generate" else ()
    for extra in (GROUNDING_ARGS, ()):
        result = CliRunner().invoke(app, [command, "--dataset", "hapt12", *where, *extra, "-o", str(tmp_path / "o")])
        assert isinstance(result.exception, ConfigError) and result.exception.message == "stop", result.output
    given, default = ({f: getattr(spec, f) for f in GROUNDING_FIELDS} for spec in seen)
    assert given == GROUNDING_FIELDS
    click_app = typer.main.get_command(app)
    options = {p.name: p.default for p in click_app.commands[command].params}
    assert default == {**{f: options[f] for f in GROUNDING_FIELDS}, "unseen_intensity": INTENSITY}
