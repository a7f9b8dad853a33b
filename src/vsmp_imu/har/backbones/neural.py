"""Neural HAR backbones on CPU PyTorch: DeepConvLSTM, DeepConvLSTM with attention,
BiLSTM with attention.

Training follows the paper's implementation details: AdamW, learning rate
1e-3, batch size 1024, early stopping on validation Macro-F1 (over the classes
the validation windows hold), up to N epochs
(the paper uses 500; the CPU default here is 60 with patience 10). Inputs are
z-scored per channel with statistics of the training windows given to `fit`.
`class_weight="balanced"` weighs each window's loss by the inverse of its
class's count (not in the paper; `evaluate --class-weight`).

One deviation for small training sets: a batch holds at most 1/`min_steps`
of the windows (default 8 steps per epoch). With the paper's 1024-window
batch a 1 % label budget (about 100 to 350 windows) gets one optimizer step
per epoch, and early stopping then ends training after a dozen steps with a
barely trained model; smaller batches give the same epochs more steps at the
same compute. Sets of 8192 windows and more keep batches of 1024.
"""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.metrics import f1_score

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.normalize import ChannelStandardizer

DEVICES = ("cpu", "cuda", "cuda:N", "mps", "auto")


def resolve_device(name: str):
    """The torch device for `--device`: cpu, cuda, cuda:N, mps, or auto (cuda when present)."""
    import torch

    text = str(name).strip().lower()
    if text == "auto":
        text = "cuda" if torch.cuda.is_available() else "cpu"
    try:
        device = torch.device(text)
    except (RuntimeError, ValueError):
        raise ConfigError(f"unknown device '{name}'", field="--device", allowed=", ".join(DEVICES)) from None
    if device.type == "cuda":
        count = torch.cuda.device_count() if torch.cuda.is_available() else 0
        if count == 0 or (device.index or 0) >= count:
            raise ConfigError(f"device '{name}' is not available: this PyTorch sees {count} CUDA device(s)",
                              field="--device", allowed="cpu, auto, or a CUDA machine with a CUDA build of PyTorch")
        # cuBLAS is deterministic only with a fixed workspace, read when its first handle is made
        os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    elif device.type == "mps" and not torch.backends.mps.is_available():
        raise ConfigError(f"device '{name}' is not available here", field="--device", allowed="cpu or auto")
    elif device.type not in ("cpu", "cuda", "mps"):
        raise ConfigError(f"unsupported device '{name}'", field="--device", allowed=", ".join(DEVICES))
    return device


def validation_score(y_true: np.ndarray, y_pred: np.ndarray) -> float:
    """Macro-F1 over the classes the validation windows hold (the early-stopping score).

    A class absent from validation (the unseen protocol removes the unseen classes'
    real windows there) is left out of the average: a window predicted as that class
    already counts against its true class, and counting the class as a zero as well
    made the score punish an epoch for every absent class it predicts, so early
    stopping could keep an epoch only because it predicted fewer of them.
    """
    labels = np.unique(y_true)
    return float(f1_score(y_true, y_pred, labels=labels, average="macro", zero_division=0))


@dataclass(eq=False, repr=False, kw_only=True)
class TorchClassifier(ClassifierMixin, BaseEstimator):
    """Shared training loop; subclasses build the network in `_build(n_channels, n_classes)`.

    `fit(X, y, X_val, y_val)`: with validation windows the weights of the epoch
    with the best validation Macro-F1 are kept and training stops after
    `patience` epochs without improvement; without them it trains
    `max_epochs` epochs and keeps the last weights. After fitting:
    `classes_`, `n_epochs_` (epochs run), `best_epoch_`, `history_`
    (per-epoch training loss and validation Macro-F1).

    `on_epoch`, when set on an instance (not a parameter: it changes no result), is called
    with each epoch's `history_` row as it ends (an evaluation's progress lines).
    """

    uses_validation = True
    on_epoch = None  # Callable[[dict[str, float]], None] | None

    max_epochs: int = 60
    patience: int = 10
    batch_size: int = 1024
    lr: float = 1e-3
    weight_decay: float = 1e-2
    random_state: int = 0
    n_threads: int | None = None
    verbose: bool = False
    min_steps: int = 8
    device: str = "cpu"
    # None: every window counts alike; "balanced": each class's windows weigh the inverse of
    # its count in the loss (scikit-learn's `class_weight="balanced"`, as the forests take it)
    class_weight: str | None = None

    @classmethod
    def _get_test_params(cls) -> dict[str, Any]:
        return {"max_epochs": 2, "patience": 2, "batch_size": 64, "n_threads": 1}

    def _build(self, n_channels: int, n_classes: int):  # pragma: no cover - abstract
        raise NotImplementedError

    # -- helpers ---------------------------------------------------------------------------
    def _tensor(self, X: np.ndarray):
        import torch

        return torch.from_numpy(self.standardizer_.transform(X)).to(self.device_)

    def _batch_size(self, n: int) -> int:
        """The training batch: `batch_size`, but at most 1/`min_steps` of the n windows."""
        return max(1, min(int(self.batch_size), -(-n // max(1, int(self.min_steps)))))

    def _batches(self, n: int, generator=None, size: int | None = None):
        import torch

        size = size or self.batch_size
        order = torch.randperm(n, generator=generator) if generator is not None else torch.arange(n)
        order = order.to(self.device_)
        for start in range(0, n, size):
            yield order[start : start + size]

    def _forward_all(self, X: np.ndarray, what: str) -> np.ndarray:
        import torch

        xt = self._tensor(X)
        self.model_.eval()
        outs = []
        with torch.no_grad():
            for idx in self._batches(len(xt)):
                out = self.model_(xt[idx]) if what == "logits" else self.model_.features(xt[idx])
                outs.append(out)
        if not outs:
            return np.zeros((0, 0), np.float32)
        return torch.cat(outs).cpu().numpy()

    # -- estimator API ---------------------------------------------------------------------
    def fit(
        self,
        X: np.ndarray,
        y: np.ndarray,
        X_val: np.ndarray | None = None,
        y_val: np.ndarray | None = None,
        sample_weight: np.ndarray | None = None,
    ) -> TorchClassifier:
        import torch

        X = np.asarray(X, dtype=np.float32)
        y = np.asarray(y)
        if X.ndim != 3 or len(X) != len(y) or len(X) == 0:
            raise ValidationError(
                f"need (N, T, C) windows and N labels, got {X.shape}, {y.shape}", field="X"
            )
        if sample_weight is not None and np.shape(sample_weight) != (len(y),):
            raise ValidationError(f"need N = {len(y)} sample weights, got shape {np.shape(sample_weight)}",
                                  field="sample_weight")
        self.classes_ = np.unique(y)
        y_idx = np.searchsorted(self.classes_, y)
        use_val = X_val is not None and y_val is not None and len(X_val) > 0
        threads = torch.get_num_threads()
        if self.n_threads:
            torch.set_num_threads(self.n_threads)
        deterministic = torch.are_deterministic_algorithms_enabled()
        torch.use_deterministic_algorithms(True, warn_only=True)
        try:
            self.device_ = resolve_device(self.device)
            with torch.random.fork_rng(devices=[]):
                torch.manual_seed(int(self.random_state))
                self.standardizer_ = ChannelStandardizer().fit(X)
                self.model_ = self._build(X.shape[2], len(self.classes_)).to(self.device_)
                self._train(X, y_idx, X_val if use_val else None, y_val if use_val else None, sample_weight)
        finally:
            torch.use_deterministic_algorithms(deterministic)
            torch.set_num_threads(threads)
        return self

    def _train(self, X, y_idx, X_val, y_val, sample_weight=None) -> None:
        import torch

        xt = self._tensor(X)
        yt = torch.from_numpy(y_idx.astype(np.int64)).to(self.device_)
        optimizer = torch.optim.AdamW(
            self.model_.parameters(), lr=self.lr, weight_decay=self.weight_decay
        )
        loss_fn = self._loss_fn(y_idx, sample_weight)
        generator = torch.Generator().manual_seed(int(self.random_state))
        best_f1, best_state, stale = -1.0, None, 0
        self.history_: list[dict[str, float]] = []
        self.best_epoch_ = 0
        for epoch in range(1, int(self.max_epochs) + 1):
            self.model_.train()
            total, count = 0.0, 0
            for idx in self._batches(len(xt), generator, self._batch_size(len(xt))):
                optimizer.zero_grad()
                loss = loss_fn(self.model_(xt[idx]), yt[idx], idx)
                loss.backward()
                optimizer.step()
                total += float(loss.detach()) * len(idx)
                count += len(idx)
            record = {"epoch": epoch, "train_loss": total / max(count, 1)}
            if X_val is not None:
                f1 = validation_score(y_val, self.predict(X_val))
                record["val_macro_f1"] = float(f1)
                if f1 > best_f1:
                    best_f1, stale, self.best_epoch_ = f1, 0, epoch
                    best_state = copy.deepcopy(self.model_.state_dict())
                else:
                    stale += 1
            else:
                self.best_epoch_ = epoch
            self.history_.append(record)
            self.n_epochs_ = epoch
            if self.on_epoch is not None:
                self.on_epoch(record)
            if self.verbose:
                import sys

                print(
                    f"epoch {epoch}: "
                    + ", ".join(f"{k} {v:.4f}" for k, v in record.items() if k != "epoch"),
                    file=sys.stderr,
                    flush=True,
                )
            if X_val is not None and stale >= self.patience:
                break
        if best_state is not None:
            self.model_.load_state_dict(best_state)

    def _loss_fn(self, y_idx: np.ndarray, sample_weight: np.ndarray | None):
        """loss(logits, targets, batch indices): the cross-entropy with the class weights, and
        with per-window weights where given (the batch's weighted mean, as the class-weighted
        cross-entropy takes it)."""
        import torch

        class_weights = self._loss_weights(y_idx)
        if sample_weight is None:
            plain = torch.nn.CrossEntropyLoss(weight=class_weights)
            return lambda logits, targets, idx: plain(logits, targets)
        weights = torch.as_tensor(np.asarray(sample_weight, np.float64), dtype=torch.float32, device=self.device_)
        if class_weights is not None:
            weights = weights * class_weights[torch.as_tensor(y_idx, device=self.device_)]
        per_window = torch.nn.CrossEntropyLoss(reduction="none")

        def loss(logits, targets, idx):
            w = weights[idx]
            return (per_window(logits, targets) * w).sum() / w.sum().clamp_min(1e-12)

        return loss

    def _loss_weights(self, y_idx: np.ndarray):
        """Per-class weights of the cross-entropy: None (all 1) or balanced, n / (k * count)."""
        import torch

        if self.class_weight is None:
            return None
        if self.class_weight != "balanced":
            raise ValidationError(f"unknown class_weight {self.class_weight!r}", field="class_weight",
                                  allowed="None or 'balanced'")
        counts = np.bincount(y_idx, minlength=len(self.classes_))
        weights = len(y_idx) / (len(self.classes_) * counts)
        return torch.as_tensor(weights, dtype=torch.float32, device=self.device_)

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        import torch

        logits = self._forward_all(np.asarray(X, dtype=np.float32), "logits")
        return torch.softmax(torch.from_numpy(logits), dim=1).numpy().astype(np.float64)

    def predict(self, X: np.ndarray) -> np.ndarray:
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]

    def embed(self, X: np.ndarray) -> np.ndarray:
        """Penultimate features (the input of the classification layer)."""
        return self._forward_all(np.asarray(X, dtype=np.float32), "features")


@dataclass(eq=False, repr=False, kw_only=True)
class DeepConvLSTM(TorchClassifier):
    """DeepConvLSTM (Ordóñez & Roggen 2016); `attention=True` pools the LSTM outputs with
    additive attention instead of taking the last step."""

    n_filters: int = 64
    kernel_size: int = 5
    n_conv: int = 4
    hidden: int = 128
    n_lstm: int = 2
    dropout: float = 0.5

    attention = False

    @classmethod
    def _get_test_params(cls) -> dict[str, Any]:
        return {**super()._get_test_params(), "n_filters": 8, "hidden": 16, "n_conv": 2}

    def _build(self, n_channels: int, n_classes: int):
        from vsmp_imu.har.backbones.networks import DeepConvLSTMNet

        return DeepConvLSTMNet(
            n_channels,
            n_classes,
            self.n_filters,
            self.kernel_size,
            self.n_conv,
            self.hidden,
            self.n_lstm,
            self.dropout,
            attention=self.attention,
        )


class DeepConvLSTMAttention(DeepConvLSTM):
    """DeepConvLSTM with self-attention over the LSTM outputs (Singh et al. 2020)."""

    attention = True


@dataclass(eq=False, repr=False, kw_only=True)
class BiLSTMAttention(TorchClassifier):
    """BiLSTM with attention (Zhang et al. 2023)."""

    hidden: int = 128
    n_lstm: int = 2
    dropout: float = 0.5

    @classmethod
    def _get_test_params(cls) -> dict[str, Any]:
        return {**super()._get_test_params(), "hidden": 16, "n_lstm": 1}

    def _build(self, n_channels: int, n_classes: int):
        from vsmp_imu.har.backbones.networks import BiLSTMAttentionNet

        return BiLSTMAttentionNet(n_channels, n_classes, self.hidden, self.n_lstm, self.dropout)
