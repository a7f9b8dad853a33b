"""The paper's two generative baselines, on the same pipeline, budget and grounding data.

IMUGPT 2.0-style (`imugpt`): activity label -> several diverse free-text
descriptions (an OpenAI-compatible LLM when configured; offline, the activity
library's captions crossed with execution modifiers) -> motion backend ->
virtual IMU -> its motion filter (plausibility) and diversity control
(redundancy) -> rank grounding. No SMP, no simulation-in-the-loop, no
class-faithfulness validator.

IMUTube-style (`imutube`): source clips -> pose (MediaPipe) -> SMPL-22 motion
-> virtual IMU -> rank grounding. No SMP, no simulation-in-the-loop; only the
motion-plausibility filter.

Both run through `vsmp_imu.pipeline.fold.FoldGenerator`, so they see exactly
the training side of each fold that VSMP-IMU sees.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError, VsmpError
from vsmp_imu.har.synthetic import FoldContext
from vsmp_imu.har.windows import Windows
from vsmp_imu.pipeline.fold import Base, FoldGenerator
from vsmp_imu.pipeline.method import fold_key
from vsmp_imu.pipeline.sources import entries_for, parse_source
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp.library import ActivityLibrary

# Offline diversity: execution modifiers appended to the library captions.
MODIFIERS = (
    "", "slowly", "quickly", "with small movements", "with large, energetic movements",
    "in a relaxed way", "carefully", "at a steady rhythm",
)
DESCRIBE_PROMPT = (
    "Write {n} different one-sentence descriptions of a person performing the activity "
    "'{activity}', as prompts for a text-to-motion model: describe the body movement only "
    "(no objects, scenery or clothing), vary speed, amplitude and style. "
    'Return JSON: {{"descriptions": ["...", "..."]}}.'
)


def offline_descriptions(captions: tuple[str, ...], n: int, seed: int, key: str) -> list[str]:
    """n distinct captions x modifiers, in a seeded order."""
    pool = [f"{c.rstrip('.')} {m}.".replace(" .", ".") if m else c for c in captions for m in MODIFIERS]
    order = rng_for(seed, "imugpt-descriptions", key).permutation(len(pool))
    return [pool[i] for i in order[:n]]


def parse_descriptions(text: str) -> tuple[list[str], str | None]:
    """(the descriptions, None) from the describer's answer: JSON `{"descriptions": [...]}` or a
    bare list of strings, fenced or not; ([], why) when it holds none (empty, a refusal, prose,
    other JSON)."""
    import json_repair

    body = (text or "").strip().removeprefix("```json").removeprefix("```").removesuffix("```")
    try:
        data = json_repair.loads(body)
    except Exception:  # json_repair raises plain exceptions (RecursionError too) on hopeless input
        data = None
    if isinstance(data, dict):
        data = data.get("descriptions")
    if not isinstance(data, list):
        return [], "no list of descriptions in the answer" if (text or "").strip() else "an empty answer"
    items = [d.strip() for d in data if isinstance(d, str) and d.strip()]
    return (items, None) if items else ([], "the answer's list holds no description text")


def unusable_descriptions(text: str) -> str | None:
    """None when the answer holds a description (so the client may cache it); else why not."""
    return parse_descriptions(text)[1]


def llm_descriptions(client, activity: str, n: int) -> list[str]:
    """Descriptions from an OpenAI-compatible chat model (`extract.client.VLMClient`, so through
    the bounded transport of `extract.http`). The client caches only usable answers
    (`unusable_descriptions`): an empty, refused or malformed one is asked again next time, and
    a damaged cache entry is a miss (with a warning)."""
    prompt = DESCRIBE_PROMPT.format(n=n, activity=activity)
    completion = client.complete([{"role": "user", "content": prompt}],
                                 key_fields={"task": "imugpt-describe", "activity": activity, "n": n},
                                 accept=unusable_descriptions)
    if completion.content is None:
        raise VsmpError(f"the description model gave no answer for '{activity}' "
                        f"({completion.error or '; '.join(completion.errors) or 'no content'})",
                        field="describer")
    items, problem = parse_descriptions(completion.content)
    if problem is not None:
        raise VsmpError(f"the description model's answer for '{activity}' is not the expected JSON "
                        f"({problem}; not cached, asked again next time)", field="describer")
    return items[:n]


class _GenerativeBaseline:
    """A baseline on the generation pipeline; `spec` carries the options and the baseline's chain
    (its switches in `vsmp_imu.methods`; `**options` replace spec fields)."""

    name = "baseline"

    def __init__(self, spec: GenerationSpec | None = None, name: str | None = None, **options: Any) -> None:
        from vsmp_imu.methods import method

        self.spec = method(name or self.name).spec(replace(spec or GenerationSpec(), **options))
        self.last_output_: Any = None

    def _bases(self, context: FoldContext, library: ActivityLibrary) -> dict[str, list[tuple[str, Base]]]:
        raise NotImplementedError

    def generate(self, context: FoldContext) -> Windows:
        spec = self.spec
        library = ActivityLibrary.load([Path(d) for d in spec.library_dirs])
        bases = self._bases(context, library)
        generator = FoldGenerator(spec, spec.make_executor(show_progress=False),
                                  Path(spec.cache_dir) if spec.cache_dir else None, library=library)
        out = generator.generate(context.dataset, context.train, bases, context.budget_vector(), context.seed,
                                 f"{self.name}-{fold_key(context)}")
        self.last_output_ = out
        return out.windows


class ImuGptMethod(_GenerativeBaseline):
    """IMUGPT 2.0-style synthetic windows (see module doc); `describer_url` names an
    OpenAI-compatible model that writes the descriptions (offline captions otherwise). Its
    answers are cached in `describer/` of the spec's own cache_dir, else (none, or the project's
    samples folder) in the project's `vlm` cache folder."""

    name = "imugpt"

    def __init__(self, spec: GenerationSpec | None = None, name: str | None = None, n_descriptions: int = 12,
                 describer_url: str | None = None, describer_model: str | None = None, **options: Any) -> None:
        super().__init__(spec, name, **options)
        self.n_descriptions = n_descriptions
        self.describer_url = describer_url
        self.describer_model = describer_model

    def _bases(self, context, library):
        info = context.dataset
        entries = entries_for(info.name, info.label_names, library)
        client = None
        if self.describer_url:
            from vsmp_imu.extract.client import VLMClient
            from vsmp_imu.har.cache import samples_dir, vlm_dir

            # paid answers: never in the current folder, nor with the samples (pruned, cleared)
            own = self.spec.cache_dir and Path(self.spec.cache_dir).resolve() != samples_dir().resolve()
            cache = Path(self.spec.cache_dir) / "describer" if own else vlm_dir()
            client = VLMClient(self.describer_url, self.describer_model or "", cache_dir=cache)
        out = {}
        for label, entry in entries.items():
            if client is not None:
                texts = llm_descriptions(client, entry.smp.activity_label, self.n_descriptions)
            else:
                captions = entry.captions or (f"A person performs {entry.smp.activity_label}.",)
                texts = offline_descriptions(captions, self.n_descriptions, context.seed, label)
            out[label] = [(f"description:{i}", text) for i, text in enumerate(texts)]
        return out


class ImuTubeMethod(_GenerativeBaseline):
    """IMUTube-style synthetic windows from source clips (see module doc)."""

    name = "imutube"

    def _bases(self, context, library):
        from vsmp_imu.pipeline.sources import SmpDirSource
        from vsmp_imu.pipeline.video_source import pool_clips

        kind, folder = parse_source(self.spec.source)
        if kind != "video":
            raise ConfigError("the IMUTube-style baseline needs source clips: --source video:DIR",
                              field="source", allowed="video:DIR")
        info = context.dataset
        matcher = SmpDirSource(folder, library)
        out: dict[str, list[tuple[str, Base]]] = {}
        for activity, clip in pool_clips(folder):
            label = _dataset_label(activity, info.name, info.label_names, library, matcher)
            if label is not None:
                out.setdefault(label, []).append((f"video:{clip.name}", self._pose_motion(clip, activity)))
        if not out:
            raise ConfigError("no source clip matches a class of the dataset", file=folder, field="source")
        return out

    def _pose_motion(self, clip: Path, activity: str) -> Path:
        """The clip's retargeted pose motion, cached next to the clip."""
        path = clip.with_name(clip.name + ".pose.npz")
        if not path.exists():
            from vsmp_imu.extract.pose import PoseExtractor

            result = PoseExtractor().extract(clip, activity)
            if result.motion is None:
                raise VsmpError("no usable pose track in the clip", file=clip)
            result.motion.save(path)
        return path


def _dataset_label(activity: str, dataset: str, label_names, library, matcher) -> str | None:
    """The dataset class a clip folder's activity name stands for."""
    from vsmp_imu.smp._text import norm_name

    wanted = {norm_name(n): n for n in label_names}
    if norm_name(activity) in wanted:
        return wanted[norm_name(activity)]
    try:
        entry = library.get(activity)
    except VsmpError:
        return None
    smp = entry.smp
    return matcher._class_of(smp, dataset, label_names)
