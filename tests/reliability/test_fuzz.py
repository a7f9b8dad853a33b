"""Fuzzing of every reader of outside input: SMP repair, the SMP loader, the dataset loaders
(generic YAML/CSV, the HAPT pickle through the restricted unpickler, the fixtures of the file
formats) and the command-line options.

The contract: a clean result, or an error of the project family (`VsmpError`)
that names the file; anything else (a bare exception, a traceback) fails.
The default run tries a few dozen cases per reader; the `slow` versions
10 000 per reader (the file-format fixtures: 2 000 per format, 10 000 in all).
"""

from __future__ import annotations

import resource
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from fuzzing import FAST_EXAMPLES, SLOW_EXAMPLES, fuzz_settings, mutated
from hypothesis import given
from hypothesis import strategies as st
from legacy_format import legacy_pickle_bytes, small_recordings

from vsmp_imu.errors import VsmpError
from vsmp_imu.smp import SMP, load_smp, save_smp
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.repair import parse_response
from vsmp_imu.units import STANDARD_GRAVITY_M_S2

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
VLM_FIXTURES = sorted((FIXTURES / "vlm").glob("*.*"))
SEEDS = [p.read_bytes() for p in VLM_FIXTURES if p.suffix in (".json", ".txt", ".md")]
FORMATS = {  # dataset name -> fixture folder
    "pamap2": FIXTURES / "datasets" / "pamap2",
    "utd-mhad": FIXTURES / "datasets" / "utd_mhad",
    "mmfit": FIXTURES / "datasets" / "mmfit",
    "mmact": FIXTURES / "datasets" / "mmact",
    "had-aw": FIXTURES / "datasets" / "had_aw",
}
FORMAT_EXAMPLES = SLOW_EXAMPLES // len(FORMATS)
ADDRESS_SPACE_LIMIT = 8 * 2**30  # a damaged file must not make a reader take the machine's memory


@pytest.fixture(scope="module", autouse=True)
def _memory_limit():
    """Cap this process's address space while fuzzing: a reader that tries to allocate what a
    damaged header claims fails with MemoryError (a test failure) instead of exhausting RAM."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = ADDRESS_SPACE_LIMIT if hard == resource.RLIM_INFINITY else min(ADDRESS_SPACE_LIMIT, hard)
    if soft == resource.RLIM_INFINITY or soft > limit:
        resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    yield
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


class Files:
    """A folder of files and their original bytes (short repr: hypothesis prints it)."""

    def __init__(self, folder: Path, files: dict[Path, bytes] | None = None) -> None:
        self.folder = folder
        self.files = files if files is not None else {
            p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}

    def __repr__(self) -> str:
        return f"Files({self.folder.name}, {len(self.files)} files)"


def expect_clean_or_vsmp_error(fn, file: Path | None = None, root: Path | None = None):
    """Run `fn`; any VsmpError is fine. When it names a file, that must be `file`, a folder
    holding it, or a file of the dataset folder `root` (a YAML file pointing at a damaged table)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fn()
    except VsmpError as exc:
        if file is not None and exc.file:
            named = Path(exc.file)
            ok = named == file or named in file.parents or (root is not None and root in named.parents)
            assert ok, f"the error names {named}, not {file}: {exc.render()}"
        return None


# -- SMP repair ------------------------------------------------------------------------------
def check_repair(raw: bytes | str) -> None:
    result = parse_response(raw)  # contract: never raises
    reason = result.report.reason or ""
    assert "internal error" not in reason, reason  # the repair code itself must not crash
    assert (result.smp is None) == result.report.rejected
    if result.smp is not None:
        assert SMP.model_validate_json(result.smp.model_dump_json()) == result.smp
        result.report.to_dict()


repair_inputs = st.one_of(
    st.sampled_from(SEEDS).flatmap(mutated),
    st.text(max_size=400),
    st.binary(max_size=400),
    st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=20),
                 lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=12), c, max_size=5),
                 max_leaves=20).map(lambda v: __import__("json").dumps(v, allow_nan=True)),
)


@fuzz_settings(FAST_EXAMPLES * 3)
@given(repair_inputs)
def test_repair_fuzz(raw):
    check_repair(raw)


@pytest.mark.slow
@fuzz_settings(SLOW_EXAMPLES)
@given(repair_inputs)
def test_repair_fuzz_10k(raw):
    check_repair(raw)


# -- SMP loader --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def smp_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("smp-fuzz")
    smp = ActivityLibrary.load().get("jumping_jacks").smp
    for suffix in (".json", ".yaml"):
        save_smp(smp, folder / f"seed{suffix}")
    return Files(folder)


def check_smp_loader(smp_files, suffix: str, data: bytes) -> None:
    path = smp_files.folder / f"case{suffix}"
    path.write_bytes(data)
    smp = expect_clean_or_vsmp_error(lambda: load_smp(path), path)
    assert smp is None or isinstance(smp, SMP)


@fuzz_settings(FAST_EXAMPLES)
@given(suffix=st.sampled_from((".json", ".yaml")), data=st.data())
def test_smp_loader_fuzz(smp_files, suffix, data):
    check_smp_loader(smp_files, suffix, data.draw(mutated(smp_files.files[smp_files.folder / f'seed{suffix}'])))


@pytest.mark.slow
@fuzz_settings(SLOW_EXAMPLES)
@given(suffix=st.sampled_from((".json", ".yaml")), data=st.data())
def test_smp_loader_fuzz_10k(smp_files, suffix, data):
    check_smp_loader(smp_files, suffix, data.draw(mutated(smp_files.files[smp_files.folder / f'seed{suffix}'])))


# -- HAPT pickle (restricted unpickler) ---------------------------------------------------------
@pytest.fixture(scope="module")
def hapt_pickle(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pickle-fuzz")
    (folder / "seed.pkl").write_bytes(legacy_pickle_bytes(small_recordings()))
    return Files(folder)


def check_hapt_pickle(hapt_pickle, data: bytes) -> None:
    from vsmp_imu.har.datasets.hapt import HAPT

    path = hapt_pickle.folder / "HAPT.pkl"
    path.write_bytes(data)
    windows = expect_clean_or_vsmp_error(lambda: HAPT(path=path, use_cache=False).windows(), path)
    if windows is not None:
        assert np.isfinite(windows.X).all()


def test_the_small_pickle_reads_like_hapt(hapt_pickle):
    from vsmp_imu.har.datasets.hapt import HAPT

    windows = HAPT(path=hapt_pickle.folder / "seed.pkl", use_cache=False).windows()
    assert len(windows) > 0 and windows.X.shape[1:] == (100, 6)
    assert windows.X[..., 0].mean() == pytest.approx(STANDARD_GRAVITY_M_S2, abs=0.1)  # 1 g on x, converted to m/s^2


@fuzz_settings(FAST_EXAMPLES)
@given(data=st.data())
def test_hapt_pickle_fuzz(hapt_pickle, data):
    check_hapt_pickle(hapt_pickle, data.draw(mutated(hapt_pickle.files[hapt_pickle.folder / 'seed.pkl'], max_ops=3)))


@pytest.mark.slow
@fuzz_settings(SLOW_EXAMPLES)
@given(data=st.data())
def test_hapt_pickle_fuzz_10k(hapt_pickle, data):
    check_hapt_pickle(hapt_pickle, data.draw(mutated(hapt_pickle.files[hapt_pickle.folder / 'seed.pkl'], max_ops=3)))


# -- generic YAML / CSV dataset ------------------------------------------------------------------
@pytest.fixture(scope="module")
def generic_copy(tmp_path_factory):
    folder = tmp_path_factory.mktemp("generic-fuzz") / "generic"
    shutil.copytree(FIXTURES / "datasets" / "generic", folder)
    return Files(folder)


def _mutate_and_load(files: Files, target: Path, data: bytes, load) -> None:
    target.write_bytes(data)
    try:
        windows = expect_clean_or_vsmp_error(load, target, files.folder)
        if windows is not None:
            assert np.isfinite(windows.X).all()
            assert windows.X.ndim == 3 and len(windows.y) == len(windows.X)
    finally:
        target.write_bytes(files.files[target])


def check_generic(generic_copy, index: int, data_strategy) -> None:
    from vsmp_imu.har.datasets import load_dataset

    folder, files = generic_copy.folder, generic_copy.files
    target = sorted(files)[index % len(files)]
    data = data_strategy.draw(mutated(files[target]))
    _mutate_and_load(generic_copy, target, data, lambda: load_dataset(folder / "dataset.yaml").windows())


@fuzz_settings(FAST_EXAMPLES)
@given(index=st.integers(0, 3), data=st.data())
def test_generic_dataset_fuzz(generic_copy, index, data):
    check_generic(generic_copy, index, data)


@pytest.mark.slow
@fuzz_settings(SLOW_EXAMPLES)
@given(index=st.integers(0, 3), data=st.data())
def test_generic_dataset_fuzz_10k(generic_copy, index, data):
    check_generic(generic_copy, index, data)


# -- file formats (fixtures in each dataset's own layout) --------------------------------------------
@pytest.fixture(scope="module")
def format_copies(tmp_path_factory):
    root = tmp_path_factory.mktemp("formats-fuzz")
    out = {}
    for name, src in FORMATS.items():
        folder = root / src.name
        shutil.copytree(src, folder)
        out[name] = Files(folder)
    return out


def check_format(format_copies, name: str, index: int, data) -> None:
    from vsmp_imu.har.datasets import load_dataset

    folder, files = format_copies[name].folder, format_copies[name].files
    target = sorted(files)[index % len(files)]
    _mutate_and_load(format_copies[name], target, data.draw(mutated(files[target], max_ops=3)),
                     lambda: load_dataset(name, folder).windows())


@pytest.mark.parametrize("name", sorted(FORMATS))
@fuzz_settings(FAST_EXAMPLES // 3)
@given(index=st.integers(0, 200), data=st.data())
def test_file_format_fuzz(format_copies, name, index, data):
    check_format(format_copies, name, index, data)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(FORMATS))
@fuzz_settings(FORMAT_EXAMPLES)
@given(index=st.integers(0, 200), data=st.data())
def test_file_format_fuzz_10k(format_copies, name, index, data):
    check_format(format_copies, name, index, data)
