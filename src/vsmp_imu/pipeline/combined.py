"""VSMP-IMU + Classical Aug (`--methods vsmp+classical`): both sources in one synthetic budget.

Per class c with budget b_c, the VSMP-IMU windows of the fold (the same ones
the `vsmp` method makes: same spec, same seed, same cache) fill up to half
of b_c (rounded up); the rest are Classical Aug copies of windows drawn from
the real training windows of c and those VSMP-IMU windows together, so the
augmentation perturbs both. Every window says where it came from: meta
`part` ("vsmp" or "classical"), `origin` ("real" or "vsmp") and `origin_sample`
(the VSMP-IMU sample an augmented copy came from, or the window's own sample).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vsmp_imu.baselines.classical import ClassicalAugmentation, sensor_triplets
from vsmp_imu.har.synthetic import FoldContext, take_budget
from vsmp_imu.har.windows import Windows
from vsmp_imu.pipeline.method import VsmpMethod
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.seeding import rng_for


def vsmp_share(budget: np.ndarray, available: np.ndarray) -> np.ndarray:
    """VSMP-IMU windows per class: half the budget rounded up, at most what was made."""
    return np.minimum((np.asarray(budget) + 1) // 2, available)


@dataclass
class VsmpClassicalMethod:
    """VSMP-IMU windows plus classical augmentation of the real and VSMP-IMU windows."""

    spec: GenerationSpec = field(default_factory=GenerationSpec)
    name: str = "vsmp+classical"
    augmentation: ClassicalAugmentation = field(default_factory=ClassicalAugmentation)

    def generate(self, context: FoldContext) -> Windows:
        real = context.train
        vsmp = VsmpMethod(spec=self.spec, name="vsmp").generate(context)
        rng = rng_for(context.seed, self.name, context.fold, context.protocol, context.label_budget)
        budget = context.budget_vector()
        n_classes = len(real.label_names)
        chosen = take_budget(vsmp, vsmp_share(budget, np.bincount(vsmp.y, minlength=n_classes)), rng)
        pool_X = np.concatenate([real.X.astype(np.float32), chosen.X.astype(np.float32)])
        pool_y = np.concatenate([real.y, chosen.y])
        std = real.X.reshape(-1, real.n_channels).std(axis=0) if len(real) else np.ones(real.n_channels)
        rest = np.maximum(budget - np.bincount(chosen.y, minlength=n_classes), 0)
        X, y, origin = self.augmentation.augment_pool(pool_X, pool_y, rest, std,
                                                      sensor_triplets(real.channel_names), rng)
        from_vsmp = origin >= len(real)
        samples = chosen.meta.get("sample", np.full(len(chosen), "", dtype=object)).astype(str)
        origin_sample = np.where(from_vsmp, samples[np.clip(origin - len(real), 0, None)]
                                 if len(chosen) else "", "")
        n_v, n_c = len(chosen), len(y)
        meta = {
            "source": np.full(n_v + n_c, self.name),
            "part": np.array(["vsmp"] * n_v + ["classical"] * n_c),
            "origin": np.array(["vsmp"] * n_v + ["vsmp" if v else "real" for v in from_vsmp]),
            "origin_sample": np.concatenate([samples, np.asarray(origin_sample, dtype=str)]).astype(str),
            "origin_index": np.concatenate([np.full(n_v, -1), np.where(from_vsmp, -1, origin)]),
        }
        return Windows(
            X=np.concatenate([chosen.X.astype(np.float32), X]),
            y=np.concatenate([chosen.y, y]).astype(np.int64),
            subjects=np.full(n_v + n_c, "synthetic"),
            label_names=real.label_names,
            channel_names=real.channel_names,
            fs_hz=real.fs_hz,
            meta=meta,
        )
