"""Distribution analysis and realism (paper, "Distribution Analysis and Realism").

For one LOPO fold: a DeepConvLSTM encoder f_theta is trained on the fold's
real training windows (early stopping on the fold's validation subjects);
every method generates its synthetic windows for that fold through the
harness's plug-in interface (same `FoldContext`, same budget); every window
is mapped to z = f_theta(x). As in the paper the embedding is the hidden
representation of the final convolutional feature layer, averaged over time
(`layer="conv"`); `layer="lstm"` takes the last LSTM state (the input of the
classification layer) instead.

Per class a, with R_a the real training embeddings and S_a a method's
synthetic ones: d_a = || mean(S_a) - mean(R_a) ||_2 in the original feature
space (paper's formula); the table reports the mean over classes with
synthetic windows. To read d_a on a scale, two references go through the
same computation: the held-out subject's real windows (the natural subject
shift, a floor for a generator) and the same windows with their labels
shuffled (what windows of the right domain but the wrong class give).
Also reported: the real spread s_a = mean ||z - mean(R_a)|| over R_a (d_a /
s_a) and the synthetic spread relative to s_a (intra-class coverage). PCA
(fitted on R, the real training embeddings) is used only for the scatter
plot.

Secondary: per channel, the two-sample Kolmogorov-Smirnov statistic between
synthetic and real training samples of a class, averaged over classes.

And a classifier two-sample test (C2ST) in the RF backbone's own feature
space: per class, a Random Forest on the windows' ECDF features learns to
tell the set's windows from the class's real training windows (the same
number from each side, at most C2ST_MAX_PER_SIDE, stratified 3-fold
cross-validation); its ROC AUC is 0.5 where the sets are indistinguishable
and 1 where every window gives itself away. The held-out subject's real
windows go through the same test (how far a new person's windows are), and
the features the forest leans on most say what gives a set away.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ConfigError, VsmpError
from vsmp_imu.methods import register_all
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.studies.methods import (
    check_methods,
    load_study_dataset,
    spec_settings,
    study_params,
    unavailable_reason,
)

Progress = Callable[[int, int, str], None]
DEFAULT_METHODS = ("vsmp", "imugpt", "classical")
REFERENCE = "real-test"  # the held-out subject's real windows
SHUFFLED = "real-test-shuffled"  # the same windows with their labels permuted
REFERENCES = (REFERENCE, SHUFFLED)
LAYERS = ("conv", "lstm")
KS_MAX_VALUES = 20000  # values per side of one KS test (seeded subsample)
C2ST_MAX_PER_SIDE = 300  # windows per side of one class's two-sample test (seeded subsample)
C2ST_FOLDS = 3
C2ST_TREES = 100
C2ST_TOP = 3  # features named per class
# Mini-batch of the encoder. The paper trains with 1024 for up to 500 epochs on a GPU; on
# CPU with a few epochs over a few thousand windows that is a handful of gradient steps,
# so the default is 128 (~25 steps per epoch on 3000 windows).
ENCODER_BATCH = 128
EMBED_BATCH = 512  # windows per forward pass when embedding


def window_embeddings(encoder, X: np.ndarray, layer: str = "conv") -> np.ndarray:
    """z = f_theta(x) of a fitted DeepConvLSTM: the final convolutional layer's features
    averaged over time (`conv`, the paper's choice) or the last LSTM state (`lstm`)."""
    import torch

    X = np.asarray(X, dtype=np.float32)
    if layer == "lstm":
        return encoder.embed(X)
    if layer != "conv":
        raise ConfigError(f"unknown embedding layer '{layer}'", field="--layer", allowed=", ".join(LAYERS))
    model = encoder.model_
    xt = torch.from_numpy(encoder.standardizer_.transform(X))
    model.eval()
    outs = []
    with torch.no_grad():
        for start in range(0, len(xt), EMBED_BATCH):
            outs.append(model.conv(xt[start:start + EMBED_BATCH]).mean(dim=1))  # (B, T', F*C) -> (B, F*C)
    if not outs:
        return np.zeros((0, encoder.n_filters * X.shape[2]), np.float32)
    return torch.cat(outs).numpy()


def class_centroid_distances(z_syn: np.ndarray, y_syn: np.ndarray, z_real: np.ndarray,
                             y_real: np.ndarray, n_classes: int) -> dict[int, dict[str, float]]:
    """Per class present on both sides: d_a, the real spread s_a and the synthetic spread."""
    out = {}
    for a in range(n_classes):
        r, s = z_real[y_real == a], z_syn[y_syn == a]
        if len(r) == 0 or len(s) == 0:
            continue
        mu_r, mu_s = r.mean(axis=0), s.mean(axis=0)
        spread_r = float(np.linalg.norm(r - mu_r, axis=1).mean())
        spread_s = float(np.linalg.norm(s - mu_s, axis=1).mean())
        d = float(np.linalg.norm(mu_s - mu_r))
        out[a] = {"distance": d, "real_spread": spread_r, "synthetic_spread": spread_s,
                  "relative_distance": d / spread_r if spread_r > 0 else None,
                  "coverage": spread_s / spread_r if spread_r > 0 else None,
                  "n_synthetic": int(len(s)), "n_real": int(len(r))}
    return out


def channel_ks(X_syn: np.ndarray, y_syn: np.ndarray, X_real: np.ndarray, y_real: np.ndarray,
               seed: int = 0) -> np.ndarray:
    """(C,) KS statistic per channel, averaged over the classes present on both sides."""
    from scipy.stats import ks_2samp

    stats = []
    for a in np.intersect1d(np.unique(y_syn), np.unique(y_real)):
        s = X_syn[y_syn == a].reshape(-1, X_syn.shape[2])
        r = X_real[y_real == a].reshape(-1, X_real.shape[2])
        rng = rng_for(seed, "ks", int(a))
        if len(s) > KS_MAX_VALUES:
            s = s[rng.choice(len(s), KS_MAX_VALUES, replace=False)]
        if len(r) > KS_MAX_VALUES:
            r = r[rng.choice(len(r), KS_MAX_VALUES, replace=False)]
        stats.append([ks_2samp(s[:, c], r[:, c]).statistic for c in range(X_syn.shape[2])])
    return np.mean(stats, axis=0) if stats else np.full(X_syn.shape[2], np.nan)


def class_c2st(X_set: np.ndarray, y_set: np.ndarray, X_real: np.ndarray, y_real: np.ndarray,
               channel_names, n_classes: int, seed: int = 0) -> dict[int, dict[str, Any]]:
    """Per class with at least C2ST_FOLDS windows on both sides: the cross-validated ROC AUC of a
    Random Forest telling the set's windows from the real ones on the ECDF features, balanced
    sides, and the features it uses most (see module doc)."""
    from sklearn.ensemble import RandomForestClassifier
    from sklearn.metrics import roc_auc_score
    from sklearn.model_selection import StratifiedKFold, cross_val_predict

    from vsmp_imu.har.features import N_LEVELS, ecdf_features, ecdf_levels

    names = [f"{c} q{q:.2f}" for c in channel_names for q in ecdf_levels(N_LEVELS)]
    out = {}
    for a in range(n_classes):
        s, r = X_set[y_set == a], X_real[y_real == a]
        n = min(len(s), len(r), C2ST_MAX_PER_SIDE)
        if n < C2ST_FOLDS:
            continue
        rng = rng_for(seed, "c2st", a)
        pair = np.concatenate([r[rng.choice(len(r), n, replace=False)], s[rng.choice(len(s), n, replace=False)]])
        F, side = ecdf_features(pair), np.repeat([0, 1], n)
        forest = RandomForestClassifier(C2ST_TREES, random_state=seed, n_jobs=1)
        folds = StratifiedKFold(C2ST_FOLDS, shuffle=True, random_state=seed)
        p = cross_val_predict(forest, F, side, cv=folds, method="predict_proba")[:, 1]
        top = np.argsort(-forest.fit(F, side).feature_importances_)[:C2ST_TOP]
        out[a] = {"auc": float(roc_auc_score(side, p)), "n_per_side": int(n),
                  "top_features": [names[i] for i in top]}
    return out


@dataclass
class RealismResults:
    settings: dict[str, Any]
    label_names: list[str]
    channel_names: list[str]
    encoder: dict[str, Any]
    skipped: dict[str, str]
    methods: list[dict[str, Any]] = field(default_factory=list)
    pca: dict[str, Any] = field(default_factory=dict)  # projected points for the figure
    elapsed_s: float = 0.0

    def to_json(self) -> dict[str, Any]:
        out = asdict(self)
        out["pca"] = {"explained_variance_ratio": self.pca.get("explained_variance_ratio")}
        return out


@dataclass
class RealismStudy:
    """Feature-space realism of several methods on one fold (see module doc).

    `run(out_dir, progress)` returns RealismResults; afterwards `encoder_` holds
    the fitted encoder and `embed(X)` maps windows to the study's embedding.
    """

    dataset: str = "hapt12"
    data_dir: Path | None = None
    fold: str | None = None
    methods: tuple[str, ...] = DEFAULT_METHODS
    seed: int = 0
    alpha: float = 0.5
    max_per_class: int | None = 150
    epochs: int = 8
    patience: int = 3
    encoder_windows: int | None = 3000  # class-stratified subset of the fold's training windows
    val_windows: int | None = 1000  # class-stratified subset of the validation subjects' windows
    layer: str = "conv"
    encoder_params: dict[str, Any] = field(default_factory=dict)
    plot_per_class: int = 60
    options: GenerationSpec = field(default_factory=GenerationSpec)
    # per method, parameters of its own beside the spec's (imugpt's describer_url and describer_model)
    method_options: dict[str, dict[str, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.methods = tuple(m for m in check_methods(self.methods) if m != "real")
        if not self.methods:
            raise ConfigError("name at least one synthetic method", field="--methods")
        if self.epochs < 1:
            raise ConfigError(f"{self.epochs} is out of range", field="--epochs", allowed="an integer >= 1")
        if self.max_per_class is not None and self.max_per_class < 1:
            raise ConfigError("must be >= 1", field="--max-per-class")
        for name in ("encoder_windows", "val_windows"):
            value = getattr(self, name)
            if value is not None and value < 1:
                raise ConfigError(f"{value} is out of range", field=f"--{name.replace('_', '-')}",
                                  allowed="a positive integer (or none: all)")
        if self.layer not in LAYERS:
            raise ConfigError(f"unknown embedding layer '{self.layer}'", field="--layer",
                              allowed=", ".join(LAYERS))

    @staticmethod
    def _stratified(windows, n: int | None, rng):
        """At most n windows, spread over the classes like the whole set (each present class
        keeps at least one)."""
        from vsmp_imu.har.protocols import subsample_per_class
        from vsmp_imu.har.synthetic import apportion

        if n is None or len(windows) <= n:
            return windows
        counts = windows.class_counts()
        keep = np.minimum(counts, np.maximum(apportion(n, counts), np.minimum(counts, 1)))
        return subsample_per_class(windows, keep, rng)

    def embed(self, X: np.ndarray) -> np.ndarray:
        """The embedding z of windows X (after `run`)."""
        return window_embeddings(self.encoder_, X, self.layer)

    def _fit_encoder(self, split, fold: str) -> dict[str, Any]:
        from vsmp_imu.har.backbones import DeepConvLSTM

        train = self._stratified(split.fit, self.encoder_windows, rng_for(self.seed, "realism-encoder", fold))
        val = self._stratified(split.val, self.val_windows, rng_for(self.seed, "realism-val", fold))
        params = {"max_epochs": self.epochs, "patience": self.patience, "random_state": self.seed,
                  "batch_size": ENCODER_BATCH, **self.encoder_params}
        self.encoder_ = DeepConvLSTM(**params)
        t0 = time.perf_counter()
        has_val = len(val) > 0
        self.encoder_.fit(train.X, train.y, val.X if has_val else None, val.y if has_val else None)
        test_acc = float(np.mean(self.encoder_.predict(split.test.X) == split.test.y)) if len(split.test) else None
        return {
            "class": "DeepConvLSTM", "params": self.encoder_.get_params(), "layer": self.layer,
            "train_windows": len(train), "fit_windows_of_fold": len(split.fit), "val_windows": len(val),
            "val_windows_of_fold": len(split.val), "val_subjects": list(split.val_subjects),
            "epochs_run": getattr(self.encoder_, "n_epochs_", None),
            "best_epoch": getattr(self.encoder_, "best_epoch_", None),
            "fit_seconds": time.perf_counter() - t0, "history": getattr(self.encoder_, "history_", []),
            "test_accuracy": test_acc}

    def run(self, out_dir: str | Path, progress: Progress | None = None) -> RealismResults:
        from sklearn.decomposition import PCA

        from vsmp_imu.har.protocols import split_fold
        from vsmp_imu.har.synthetic import (
            FoldContext,
            check_synthetic,
            make_method,
            synthetic_budget,
            take_budget,
        )

        start = time.perf_counter()
        out = Path(out_dir)
        register_all()
        library = ActivityLibrary.load([Path(d) for d in self.options.library_dirs])
        study_ds = load_study_dataset(self.dataset, self.data_dir, library)
        info = study_ds.info
        windows = study_ds.dataset.windows()
        subjects = windows.unique_subjects()
        fold = str(self.fold) if self.fold is not None else subjects[0]
        if fold not in subjects:
            raise ConfigError(f"fold {fold} is not a subject of the dataset", field="--fold",
                              allowed=", ".join(subjects))
        options = self.options
        if options.cache_dir is None:
            options = replace(options, cache_dir=str(out / "cache"))
        steps = 2 + len(self.methods)

        def tick(done: int, stage: str) -> None:
            if progress:
                progress(done, steps, stage)

        split = split_fold(windows, fold, "lopo", self.seed)
        if len(split.test) == 0 or len(split.fit) == 0:
            raise ConfigError(f"fold {fold} leaves no training or no held-out window", field="--fold")
        tick(0, "training the DeepConvLSTM encoder")
        encoder_info = self._fit_encoder(split, fold)
        tick(1, "embedding the real windows")
        z_real = self.embed(split.fit.X)
        z_test = self.embed(split.test.X)
        budget = synthetic_budget(split.fit.class_counts(), self.alpha)
        if self.max_per_class is not None:
            budget = np.minimum(budget, self.max_per_class)
        names = info.label_names
        context = FoldContext(dataset=info, fold=fold, held_out_subject=fold, train=split.fit,
                              train_subjects=tuple(split.fit.unique_subjects()), seed=self.seed,
                              budget={names[i]: int(n) for i, n in enumerate(budget) if n > 0},
                              alpha=self.alpha, protocol="lopo")
        skipped: dict[str, str] = {}
        shown = [study_ds.original(n) for n in names]
        y_shuffled = rng_for(self.seed, "realism-shuffle", fold).permutation(split.test.y)
        rows = [self._row(REFERENCE, z_test, split.test.y, split.test.X, z_real, split.fit, info, shown),
                self._row(SHUFFLED, z_test, y_shuffled, split.test.X, z_real, split.fit, info, shown)]
        synthetic: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for i, m in enumerate(self.methods):
            tick(2 + i, f"generating {m} windows")
            reason = unavailable_reason(m, options, info.name, names, library)
            if reason is None:
                try:
                    syn = make_method(m, **study_params(m, options, self.method_options)).generate(context)
                    check_synthetic(split.fit, syn, m)
                    syn = take_budget(syn, budget, rng_for(self.seed, "take-budget", fold, m))
                    if len(syn) == 0:
                        reason = "the method produced no window for this fold"
                except VsmpError as exc:
                    reason = f"generation failed: {exc}"
            if reason is not None:
                skipped[m] = reason
                continue
            z = self.embed(syn.X)
            rows.append(self._row(m, z, syn.y, syn.X, z_real, split.fit, info, shown))
            synthetic[m] = (z, syn.y)
        tick(steps, "PCA")
        pca = PCA(n_components=2, random_state=0).fit(z_real)
        plot = self._plot_points(pca, z_real, split.fit.y, z_test, split.test.y, synthetic)
        results = RealismResults(
            settings={"dataset": info.name, "data_dir": self.data_dir, "fold": fold, "seed": self.seed,
                      "alpha": self.alpha, "max_per_class": self.max_per_class,
                      "budget": {names[i]: int(n) for i, n in enumerate(budget)},
                      "requested_methods": list(self.methods), "generation": spec_settings(options),
                      "method_options": self.method_options,
                      "dataset_notes": study_ds.notes, "protocol": "lopo (full training split)"},
            label_names=shown, channel_names=list(info.channel_names),
            encoder=encoder_info, skipped=skipped, methods=rows, pca=plot)
        results.elapsed_s = time.perf_counter() - start
        return results

    def _row(self, method: str, z: np.ndarray, y: np.ndarray, X: np.ndarray, z_real: np.ndarray,
             real, info, shown: list[str]) -> dict[str, Any]:
        per_class = class_centroid_distances(z, y, z_real, real.y, info.n_classes)
        ks = channel_ks(X, y, real.X, real.y, self.seed) if len(X) else np.full(real.n_channels, np.nan)
        c2st = class_c2st(X, y, real.X, real.y, info.channel_names, info.n_classes, self.seed)

        def mean_of(key: str) -> float | None:
            values = [v[key] for v in per_class.values() if v[key] is not None]
            return float(np.mean(values)) if values else None

        return {"method": method, "n_windows": int(len(y)), "classes": len(per_class),
                "mean_distance": mean_of("distance"), "mean_relative_distance": mean_of("relative_distance"),
                "mean_coverage": mean_of("coverage"),
                "per_class": {shown[a]: v for a, v in per_class.items()},
                "ks_per_channel": dict(zip(info.channel_names, ks.tolist(), strict=True)),
                "ks_mean": float(np.nanmean(ks)) if np.isfinite(ks).any() else None,
                "c2st": {shown[a]: v for a, v in c2st.items()},
                "c2st_mean_auc": float(np.mean([v["auc"] for v in c2st.values()])) if c2st else None}

    def _plot_points(self, pca, z_real, y_real, z_test, y_test, synthetic) -> dict[str, Any]:
        """Projected points (at most `plot_per_class` per class and set, seeded) and the
        projected class centroids of every set (from all its windows)."""

        def pick(z, y, key):
            idx = []
            for a in np.unique(y):
                members = np.flatnonzero(y == a)
                if len(members) > self.plot_per_class:
                    members = np.sort(rng_for(self.seed, "realism-plot", key, int(a)).choice(
                        members, self.plot_per_class, replace=False))
                idx.append(members)
            idx = np.concatenate(idx) if idx else np.zeros(0, int)
            centroids = {int(a): pca.transform(z[y == a].mean(axis=0, keepdims=True))[0].tolist()
                         for a in np.unique(y)}
            return {"xy": pca.transform(z[idx]) if len(idx) else np.zeros((0, 2)), "y": y[idx],
                    "centroids": centroids}

        sets = {"real": pick(z_real, y_real, "real"), REFERENCE: pick(z_test, y_test, REFERENCE)}
        for m, (z, y) in synthetic.items():
            sets[m] = pick(z, y, m)
        return {"sets": sets, "explained_variance_ratio": pca.explained_variance_ratio_.tolist()}
