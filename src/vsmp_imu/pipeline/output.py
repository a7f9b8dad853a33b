"""Write a generated synthetic set: Parquet windows with provenance, SMPs, prompts, summary.

Layout of an output folder:
  synthetic.parquet   one row per generated window (rejected ones too), with
                      label, sample key, window index, kept/selected flags, the
                      intensity factor (a class without real windows), the
                      window as a flat float32 list (+ its shape) and JSON
                      provenance (source, SMP variant, prompt, backend, seed,
                      theta, eta*, gamma) and filter verdicts with reasons
  smps/               the SMP variants used, one JSON per sample
  prompts.jsonl       sample key -> verbalized prompt
  motions/            the motions (.npz), when kept
  summary.json        per-class counts, filter statistics, tau_cls, config
  generate.json       the dataset and held-out subject, written before any work
                      (`vsmp-imu generate` only: `claim_output`)
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.windows import Windows
from vsmp_imu.io import write_bytes, write_json, write_text
from vsmp_imu.output_folder import entries, listing, read_json_object
from vsmp_imu.pipeline.fold import FoldOutput
from vsmp_imu.pipeline.sample import json_default, sample_stem

RUN_FILE = "generate.json"  # the dataset and held-out subject of a `generate` folder (claim_output)
OUTPUT_FILES = ("synthetic.parquet", "prompts.jsonl", "summary.json")  # and smps/*.json, motions/*.npz
MAX_SUMMARY_BYTES = 64 * 2**20  # a larger summary.json is not one `generate` wrote


def _dumps(value: Any) -> str:
    return json.dumps(value, sort_keys=True, default=json_default, separators=(",", ":"))


def parquet_table(out: FoldOutput, all_windows: np.ndarray, channel_names: tuple[str, ...],
                  fs_hz: float) -> pa.Table:
    """One row per record; windowed records carry their data."""
    rows: dict[str, list] = {k: [] for k in ("sample", "label", "window", "start_s", "kept", "selected",
                                             "intensity", "error", "data", "provenance", "verdicts")}
    for i, rec in enumerate(out.records):
        has_data = rec.windowed and i < len(all_windows)
        rows["sample"].append(rec.sample)
        rows["label"].append(rec.label)
        rows["window"].append(rec.window)
        rows["start_s"].append(rec.start_s)
        rows["kept"].append(bool(rec.kept))
        rows["selected"].append(bool(rec.selected))
        rows["intensity"].append(rec.intensity)
        rows["error"].append(rec.error)
        rows["data"].append(all_windows[i].astype(np.float32).ravel().tolist() if has_data else None)
        rows["provenance"].append(_dumps(rec.provenance.as_dict()))
        rows["verdicts"].append(_dumps([v.as_dict() for v in rec.verdicts]))
    schema = pa.schema([
        ("sample", pa.string()), ("label", pa.string()), ("window", pa.int32()), ("start_s", pa.float64()),
        ("kept", pa.bool_()), ("selected", pa.bool_()),
        ("intensity", pa.float64()), ("error", pa.string()),
        ("data", pa.list_(pa.float32())), ("provenance", pa.string()), ("verdicts", pa.string()),
    ], metadata={
        "channel_names": json.dumps(list(channel_names)),
        "window_shape": json.dumps([int(all_windows.shape[1]) if len(all_windows) else 0, len(channel_names)]),
        "fs_hz": str(fs_hz),
    })
    return pa.Table.from_pydict(rows, schema=schema)


def write_parquet(path: Path, table: pa.Table) -> Path:
    buf = io.BytesIO()
    pq.write_table(table, buf, compression="zstd")
    return write_bytes(path, buf.getvalue())


def read_synthetic(path: str | Path, label_names: tuple[str, ...] | None = None,
                   selected_only: bool = True) -> Windows:
    """The synthetic windows of a `synthetic.parquet` as `Windows`."""
    path = Path(path)
    if not path.exists():
        raise InputFileError("file not found", file=path)
    try:
        table = pq.read_table(path)
    except Exception as exc:
        raise InputFileError(f"not a readable Parquet file ({exc})", file=path) from exc
    meta = {k.decode(): v.decode() for k, v in (table.schema.metadata or {}).items()}
    channels = tuple(json.loads(meta["channel_names"]))
    t, c = json.loads(meta["window_shape"])
    df = table.to_pandas()
    df = df[df["data"].notna()]
    if selected_only:
        df = df[df["selected"]]
    names = label_names or tuple(dict.fromkeys(df["label"]))
    X = np.stack([np.asarray(d, dtype=np.float32).reshape(t, c) for d in df["data"]]) if len(df) else \
        np.zeros((0, t, c), np.float32)
    y = np.array([names.index(n) for n in df["label"]], dtype=np.int64)
    return Windows(X, y, np.full(len(df), "synthetic"), names, channels, float(meta["fs_hz"]),
                   meta={"sample": df["sample"].to_numpy().astype(str)})


def write_output(folder: Path, out: FoldOutput, extra_summary: dict[str, Any]) -> None:
    """Everything a generation run leaves behind (each file written atomically)."""
    folder.mkdir(parents=True, exist_ok=True)
    w = out.windows
    write_parquet(folder / "synthetic.parquet", parquet_table(out, out.generated, w.channel_names, w.fs_hz))
    for task in out.tasks:
        write_text(folder / "smps" / f"{sample_stem(task.key)}.json",
                   json.dumps(json.loads(task.smp_json), indent=2, sort_keys=True) + "\n")
    prompts, seen = [], set()
    for result in out.samples:
        prov = result.provenance
        if result.key in seen or prov.failed:
            continue
        seen.add(result.key)
        prompts.append(_dumps({"sample": result.key, "label": prov.label, "prompt": prov.prompt,
                               "smp_id": prov.smp_id}))
    write_text(folder / "prompts.jsonl", "".join(p + "\n" for p in prompts))
    write_json(folder / "summary.json", json.loads(_dumps({**out.summary, **extra_summary})))


def claim_output(folder: Path, dataset: str, holdout: str) -> None:
    """Take `folder` for the `generate` run of `dataset` with `holdout` held out, before any work.

    A new or empty folder is taken, and so is one of an earlier run of the same dataset and
    held-out subject (a killed run to resume, or a rerun): that run's outputs are removed first,
    so the folder never mixes two runs; its per-sample cache (`cache/`) stays, for the samples
    to be reused. A folder that holds anything else is refused (ConfigError).
    """
    held_entries = entries(folder)
    if held_entries:
        held = earlier_fold(folder)
        if held != (dataset, holdout):
            raise ConfigError(_holds(held, held_entries, dataset, holdout), file=folder, field="--output",
                              allowed="a new or empty folder, or the folder of an earlier `vsmp-imu generate` of "
                                      "the same dataset and held-out subject (rerun: its outputs are replaced); "
                                      "give another -o, or remove the folder")
        _remove_outputs(folder)
    write_json(folder / RUN_FILE, {"command": "vsmp-imu generate", "dataset": dataset, "holdout": holdout})


def earlier_fold(folder: Path) -> tuple[str, str] | None:
    """(dataset, held-out subject) of the `generate` run in `folder`, read from its RUN_FILE (or the
    summary.json of a run written before RUN_FILE was); None when neither names them."""
    for name in (RUN_FILE, "summary.json"):
        data = read_json_object(folder / name, MAX_SUMMARY_BYTES)
        if data is not None and isinstance(data.get("dataset"), str) and isinstance(data.get("holdout"), str):
            return data["dataset"], data["holdout"]
    return None


def _holds(held: tuple[str, str] | None, found: list[Path], dataset: str, holdout: str) -> str:
    if held is not None:
        return (f"holds the output of `vsmp-imu generate` for {held[0]} with held-out subject {held[1]}, "
                f"not {dataset} with {holdout}")
    return f"is not empty and holds no earlier `vsmp-imu generate` run ({listing(found)})"


def _remove_outputs(folder: Path) -> None:
    for path in (*(folder / n for n in OUTPUT_FILES), *folder.glob("smps/*.json"), *folder.glob("motions/*.npz")):
        path.unlink(missing_ok=True)
