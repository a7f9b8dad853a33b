"""The generic format refuses what would silently change the data (a class declared twice, ids
read as numbers, one column feeding two channels, a key written twice, rounded times) and warns
where one file or the gravity declaration disagrees with the values."""

from __future__ import annotations

import shutil

import pandas as pd
import pytest

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.datasets.generic import MAX_RATE_HZ, REPEATS_NOTED, REPEATS_REFUSED


@pytest.fixture
def root(tmp_path, fixtures_dir):
    target = tmp_path / "g"
    shutil.copytree(fixtures_dir / "generic", target)
    return target


def _edit(root, old: str, new: str):
    path = root / "dataset.yaml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))
    return path


def _refused(path, *words: str) -> str:
    with pytest.raises(ValidationError) as err:
        load_dataset(path)
    text = err.value.render()
    for word in words:
        assert word in text, text
    assert "Value error" not in text
    return text


@pytest.mark.parametrize("old,new,words", [
    ("labels: [walk, sit]", "labels: [walk, sit, walk]", ("dataset.yaml", "'walk' is declared twice")),
    ("labels: [walk, sit]", "labels: [walk, sit, ' ']", ("class name in labels is empty",)),
    ("unlabelled: [none]", "unlabelled: [none, sit]", ("sit: both a class",)),
    ("gyr: [gx, gy, gz]", "gyr: [gx, gx, gz]", ("locations[0]", "column 'gx' feeds two channels")),
    ("gyr: [gx, gy, gz]", "gyr: [ax, ay, az]", ("column 'ax' feeds two channels",)),
    ("fs_hz: 50 ", "fs_hz: 50\nfs_hz: 25 ", ("key 'fs_hz' appears twice (lines 5 and 6)",)),
    ("fs_hz: 50 ", "fs_hz: true ", ("field 'fs_hz'", "not true or false")),
    ("fs_hz: 50 ", "fs_hz: 1e12 ", ("field 'fs_hz'", f"{MAX_RATE_HZ:g}")),
    ("fs_hz: 50 ", "fs_hz: 0.001 ", ("field 'fs_hz'", ">= 1")),
    ("labels: [walk, sit]", "labels: [walk, sit]\nclass_min_share: {walk: 5.0}",
     ("class_min_share.walk", "<= 1")),
    ("labels: [walk, sit]", "labels: [walk, sit]\nclass_min_share: {wlak: 0.5}",
     ("field 'class_min_share'", "unknown class(es) wlak", "walk, sit")),
    # one column in two roles: the classes became the 'subjects' of leave-one-subject-out,
    # a channel the clock, a class one recording of discontiguous runs
    ("subject_column: subject", "subject_column: label",
     ("column 'label' is both subject_column and label_column",)),
    ("time_column: t", "time_column: ax", ("column 'ax' is both time_column and locations[0].acc",)),
    ("label_column: label", "label_column: label\nsession_column: label",
     ("column 'label' is both label_column and session_column",)),
])
def test_a_spec_that_would_change_the_data_silently_is_refused(root, old, new, words):
    _refused(_edit(root, old, new), *words)


def test_ids_are_read_as_written(root):
    """'01' and '1' are two people: read as numbers they would merge into one held-out subject."""
    csv = root / "data" / "p2.csv"
    frame = pd.read_csv(csv)
    frame["subject"] = "01"
    frame.to_csv(csv, index=False)
    csv = root / "data" / "p1.csv"
    frame = pd.read_csv(csv)
    frame["subject"] = "1"
    frame.to_csv(csv, index=False)
    assert sorted(load_dataset(root / "dataset.yaml").windows().unique_subjects()) == ["01", "1", "p3"]


def test_na_words_are_ids_and_labels_not_empty_cells(root):
    """pandas reads 'NA', 'None', 'null' as missing: a subject's initials and a 'None' activity were
    refused as empty cells although the cells are not empty."""
    for name, subject, walk, none in (("p1", "NA", "null", "None"), ("p2", "p2", "null", "None")):
        csv = root / "data" / f"{name}.csv"
        frame = pd.read_csv(csv, dtype=str, keep_default_na=False)
        frame["subject"] = subject
        frame["label"] = frame["label"].replace({"walk": walk, "none": none})
        frame.to_csv(csv, index=False)
    path = _edit(root, "labels: [walk, sit]", "labels: [walk, sit, 'null']")
    path = _edit(root, "unlabelled: [none]", "unlabelled: [none, 'None']")
    ds = load_dataset(path)
    assert sorted(ds.windows().unique_subjects()) == ["NA", "p2", "p3"]
    assert ds.info.label_names == ("walk", "sit", "null")
    csv = root / "data" / "p3.csv"  # a truly empty cell is still refused
    frame = pd.read_csv(csv, dtype=str, keep_default_na=False)
    frame.loc[3, "label"] = ""
    frame.to_csv(csv, index=False)
    _refused(path, "p3.csv", "field 'label'", "1 empty or blank value(s), first at data row 4")


def test_a_table_without_rows_is_refused(root):
    """A header-only file (a failed export) silently took its subject out of the dataset."""
    csv = root / "data" / "p2.csv"
    csv.write_text(csv.read_text().splitlines()[0] + "\n")
    with pytest.raises(InputFileError) as err:
        load_dataset(root / "dataset.yaml")
    assert "p2.csv" in err.value.render() and "no data rows" in err.value.render()


def _relabel(root, name: str, old: str, new: str) -> None:
    csv = root / "data" / f"{name}.csv"
    frame = pd.read_csv(csv, dtype=str, keep_default_na=False)
    frame.loc[frame["label"] == old, "label"] = new
    frame.to_csv(csv, index=False)


@pytest.mark.parametrize("declared,variant,words", [
    (False, "walk ", ("field 'label'", "'walk' and 'walk '", "one spelling per class")),
    (False, "Walk", ("field 'label'", "'Walk' and 'walk'")),
    (True, "Walk", ("field 'labels'", "'walk' and 'Walk'")),
    (False, "  ", ("p1.csv", "field 'label'", "200 empty or blank value(s), first at data row 1")),
    (True, "walk ", ("field 'labels'", "label value(s) 'walk ' are not declared")),
])
def test_class_names_that_look_alike_are_refused(root, declared, variant, words):
    """'walk ' and 'walk' (or 'Walk') were two classes printed alike and given one activity's
    synthetic windows; a label of spaces was a class with a blank name."""
    _relabel(root, "p1", "walk", variant)
    path = root / "dataset.yaml"
    if not declared:
        path = _edit(root, "labels: [walk, sit]", "# labels from the data")
    elif variant == "Walk":
        path = _edit(root, "labels: [walk, sit]", "labels: [walk, sit, Walk]")
    _refused(path, *words)


def test_a_class_spelled_like_an_unlabelled_value_is_refused(root):
    """'None' in one file beside unlabelled 'none' was a class of its own."""
    _relabel(root, "p1", "none", "None")
    _refused(_edit(root, "labels: [walk, sit]", "# labels from the data"), "field 'label'",
             "'None' are a class, while unlabelled lists 'none'", "'None' added to unlabelled")


def test_a_declared_class_without_rows_is_warned(root):
    ds = load_dataset(_edit(root, "labels: [walk, sit]", "labels: [walk, sit, run]"))
    assert len(ds.warnings) == 1 and "'run' declared in labels are in no row" in ds.warnings[0]


def test_one_table_saved_twice_is_refused(root):
    """p1.csv and p1.parquet (a table converted, the original left beside it) were both read: the
    subject's windows twice, under one recording id."""
    pd.read_csv(root / "data" / "p1.csv").to_parquet(root / "data" / "p1.parquet")
    with pytest.raises(InputFileError) as err:
        load_dataset(root / "dataset.yaml")
    assert "p1.csv and p1.parquet share a name" in err.value.render()


def test_a_column_named_twice_in_a_header_is_refused(root):
    """pandas renames the second 'ax' to 'ax.1', and the first was taken without a word."""
    csv = root / "data" / "p2.csv"
    frame = pd.read_csv(csv)
    frame.insert(4, "ax.x", frame["ax"] * 9.81)
    frame.rename(columns={"ax.x": "ax"}).to_csv(csv, index=False)
    _refused(root / "dataset.yaml", "p2.csv", "field 'ax'", "appear twice in the header")


@pytest.mark.parametrize("how,words", [
    ({"header": False}, ("field 'subject'", "column missing; none of the declared columns is in the first row",
                         "without a header row")),
    ({"sep": ";"}, ("field 'subject'", "one column holding ';': columns must be separated by commas")),
])
def test_a_table_without_a_header_or_with_another_separator_says_so(root, how, words):
    """Both were refused with 'column missing' and the first data row, or the whole header, as the
    allowed column names."""
    csv = root / "data" / "p2.csv"
    pd.read_csv(csv).to_csv(csv, index=False, **how)
    _refused(root / "dataset.yaml", "p2.csv", *words)


def test_a_time_column_in_milliseconds_names_the_time_column(root):
    for csv in (root / "data").glob("*.csv"):
        frame = pd.read_csv(csv)
        frame["t"] *= 1000.0
        frame.to_csv(csv, index=False)
    _refused(_edit(root, "fs_hz: 50 ", "# no rate "), "field 'time_column'", "median time step is 20 s",
             "are the times in seconds")


def _round_times(root, share: float) -> None:
    """Give `share` of p1.csv's rows the time of the row before them."""
    csv = root / "data" / "p1.csv"
    frame = pd.read_csv(csv)
    every = int(round(1 / share))
    frame.loc[frame.index % every == 1, "t"] = frame["t"].shift(1)
    frame.to_csv(csv, index=False)


def test_rounded_times_are_refused_and_a_few_repeats_noted(root):
    shutil.copy(root / "data" / "p1.csv", root / "p1.csv")
    _round_times(root, 2 * REPEATS_REFUSED)
    _refused(root / "dataset.yaml", "p1.csv", "field 't'", "repeat an earlier row's time", "look rounded")
    shutil.copy(root / "p1.csv", root / "data" / "p1.csv")
    _round_times(root, 0.5 * (REPEATS_NOTED + REPEATS_REFUSED))
    ds = load_dataset(root / "dataset.yaml")
    assert [w for w in ds.warnings if "p1.csv" in w and "only the first of each is kept" in w]


def test_a_value_too_large_once_converted_names_the_csv(root):
    csv = root / "data" / "p2.csv"
    frame = pd.read_csv(csv)
    frame.loc[4, "gx"] = 1e300  # deg/s: finite as written, inf in float32 rad/s
    frame.to_csv(csv, index=False)
    _refused(root / "dataset.yaml", "p2.csv", "field 'gx'", "too large", "data row 5")


def test_a_value_beyond_any_wearable_sensor_is_warned_with_its_row(root):
    """-9999 (a fill value) in a file declared in g was loaded as 9999 g without a word: it swamps
    its windows' statistics (data check then said the simulation moves '0.0x as much')."""
    csv = root / "data" / "p2.csv"
    frame = pd.read_csv(csv)
    frame.loc[6, "ax"] = -9999.0
    frame.loc[[8, 9], "gz"] = 1e5  # deg/s
    frame.loc[10, "ay"] = 16.0  # a hard impact: within a wearable accelerometer's range
    frame.to_csv(csv, index=False)
    warnings = load_dataset(root / "dataset.yaml").warnings
    assert len(warnings) == 2, warnings
    assert "p2.csv: 1 value(s) of column 'ax' beyond" in warnings[0] and "data row 7: -9999 g" in warnings[0]
    assert "2 value(s) of column 'gz'" in warnings[1] and "data row 9: 100000 deg/s" in warnings[1]


@pytest.mark.parametrize("rate,words", [("500", "interpolated 10x up"), ("10", "resampled 5x down")])
def test_fs_hz_far_from_the_time_columns_rate_is_warned(root, rate, words):
    """fs_hz: 500 on readings 20 ms apart was resampled onto 500 Hz without a word."""
    warnings = load_dataset(_edit(root, "fs_hz: 50 ", f"fs_hz: {rate} ")).warnings
    assert len(warnings) == 1 and f"fs_hz is {rate} Hz but the time column 't' steps at 50 Hz" in warnings[0]
    assert words in warnings[0]


def test_one_file_in_another_unit_is_named(root):
    assert load_dataset(root / "dataset.yaml").warnings == []
    csv = root / "data" / "p3.csv"
    frame = pd.read_csv(csv)
    frame[["ax", "ay", "az"]] *= 9.80665  # m/s² in a dataset declared in g
    frame.to_csv(csv, index=False)
    warnings = load_dataset(root / "dataset.yaml").warnings
    assert len(warnings) == 1 and "p3.csv" in warnings[0] and "look like m/s², not g" in warnings[0]


def test_gravity_declared_removed_but_present_is_warned(root):
    path = _edit(root, "gravity_included: true", "gravity_included: false")
    warnings = load_dataset(path).warnings
    assert warnings and all("gravity_included is false" in w for w in warnings)
    assert {w.split("class '")[1].split("'")[0] for w in warnings} == {"walk", "sit"}


def test_a_subject_without_windows_is_named_by_evaluate(cli, root):
    """p3 (0.6 s of data) was silently no fold of --folds all, and --folds p3 called it 'not in
    dataset' although dataset info lists it."""
    csv = root / "data" / "p3.csv"
    pd.read_csv(csv).iloc[:30].to_csv(csv, index=False)
    path = root / "dataset.yaml"
    args = ("evaluate", "--dataset", path, "--methods", "real", "--backbones", "rf", "--seeds", "1")
    code, _, err = cli(*args, "--folds", "p3", "-o", root / "ev3")
    assert code == 2 and "p3: in the recordings but no labelled window of 2 s" in err and "0.58 s" in err, err
    code, _, err = cli(*args, "--folds", "all", "-o", root / "ev")
    assert code == 0 and "subject(s) p3 give no labelled window of 2 s and are no fold" in err, err
    assert err.count("are no fold") == 1


def test_a_dataset_name_with_slashes_stays_inside_the_output_folder(cli, root):
    """The name went into the confusion figure's file name as written: 'name: ../../../escaped' wrote
    the PNG beside the output folder ('confusion_..' became a folder in it)."""
    path = _edit(root, "name: my_waist_phone", "name: ../../../escaped")
    out = root / "a" / "b" / "ev"
    code, _, err = cli("evaluate", "--dataset", path, "--methods", "real", "--backbones", "rf", "--folds", "p1",
                       "-o", out)
    assert code == 0, err
    assert [p for p in root.rglob("*escaped*") if out not in p.parents] == []
    assert [p.name for p in out.iterdir() if "escaped" in p.name] == ["confusion_..-..-..-escaped_lopo_full_rf_real.png"]


def test_hidden_files_are_skipped_and_tables_in_subfolders_warned(root):
    """A Mac's '._p1.csv' beside p1.csv stopped the dataset (cannot read table); tables in a
    subfolder were left out without a word."""
    (root / "data" / "._p1.csv").write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X        ")
    (root / "data" / "more").mkdir()
    shutil.copy(root / "data" / "p1.csv", root / "data" / "more" / "p4.csv")
    ds = load_dataset(root / "dataset.yaml")
    assert [p.name for p in ds.tables] == ["p1.csv", "p2.csv", "p3.csv"]
    assert len(ds.warnings) == 1 and "subfolder(s) more are not read" in ds.warnings[0]


def test_a_gyroscope_in_deg_s_declared_rad_s_is_warned(root):
    """Walking at a median of ~100 deg/s read as 100 rad/s without a word."""
    for csv in (root / "data").glob("*.csv"):
        frame = pd.read_csv(csv)
        frame[["gx", "gy", "gz"]] *= 30.0  # ~100 deg/s, a wrist or thigh while walking
        frame.to_csv(csv, index=False)
    assert load_dataset(root / "dataset.yaml").warnings == []
    warnings = load_dataset(_edit(root, "gyr_unit: deg/s", "gyr_unit: rad/s")).warnings
    units = [w for w in warnings if "look like deg/s; set gyr_unit: deg/s" in w]
    assert [w.split("class '")[1].split("'")[0] for w in units] == ["walk"], warnings
    # the fastest readings are also past any gyroscope's range, which says the unit may be why
    assert all("or deg/s values declared as rad/s" in w for w in warnings if w not in units)
