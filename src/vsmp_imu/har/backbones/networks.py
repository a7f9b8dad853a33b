"""PyTorch networks of the neural backbones. Each maps `(B, T, C)` windows to
class logits and exposes `features(x)`, the penultimate representation."""

from __future__ import annotations

import torch
from torch import nn


class ConvStack(nn.Module):
    """DeepConvLSTM's convolutional front: `n_layers` 2-D convolutions with (k, 1)
    kernels along time, applied to each channel separately, ReLU after each."""

    def __init__(self, n_filters: int = 64, kernel_size: int = 5, n_layers: int = 4) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        for i in range(n_layers):
            layers += [
                nn.Conv2d(1 if i == 0 else n_filters, n_filters, (kernel_size, 1)),
                nn.ReLU(),
            ]
        self.net = nn.Sequential(*layers)
        self.shrink = n_layers * (kernel_size - 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # (B, T, C) -> (B, F, T', C) -> (B, T', F * C)
        z = self.net(x.unsqueeze(1))
        b, f, t, c = z.shape
        return z.permute(0, 2, 1, 3).reshape(b, t, f * c)


class AttentionPool(nn.Module):
    """Additive attention over time: softmax(v . tanh(W h_t)) weights, weighted sum of h_t."""

    def __init__(self, dim: int, attn_dim: int = 64) -> None:
        super().__init__()
        self.proj = nn.Linear(dim, attn_dim)
        self.score = nn.Linear(attn_dim, 1, bias=False)

    def forward(self, h: torch.Tensor) -> torch.Tensor:
        weights = torch.softmax(self.score(torch.tanh(self.proj(h))).squeeze(-1), dim=1)
        return torch.einsum("bt,btd->bd", weights, h)


class DeepConvLSTMNet(nn.Module):
    """DeepConvLSTM (Ordóñez & Roggen 2016): 4 conv layers of 64 (5x1) filters, two LSTM
    layers of 128 units, dropout 0.5, softmax on the last time step."""

    def __init__(
        self,
        n_channels: int,
        n_classes: int,
        n_filters: int = 64,
        kernel_size: int = 5,
        n_conv: int = 4,
        hidden: int = 128,
        n_lstm: int = 2,
        dropout: float = 0.5,
        attention: bool = False,
    ) -> None:
        super().__init__()
        self.conv = ConvStack(n_filters, kernel_size, n_conv)
        self.drop = nn.Dropout(dropout)
        self.lstm = nn.LSTM(
            n_filters * n_channels,
            hidden,
            num_layers=n_lstm,
            batch_first=True,
            dropout=dropout if n_lstm > 1 else 0.0,
        )
        self.attention = AttentionPool(hidden) if attention else None
        self.head = nn.Linear(hidden, n_classes)

    def features(self, x: torch.Tensor) -> torch.Tensor:
        h, _ = self.lstm(self.drop(self.conv(x)))
        if self.attention is not None:
            return self.attention(h)
        return h[:, -1]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.drop(self.features(x)))


class BiLSTMAttentionNet(nn.Module):
    """BiLSTM with attention (Zhang et al. 2023): stacked bidirectional LSTM over the raw
    window, additive attention pooling over time, dropout, linear classifier."""

    def __init__(
        self,
        n_channels: int,
        n_classes: int,
        hidden: int = 128,
        n_lstm: int = 2,
        dropout: float = 0.5,
    ) -> None:
        super().__init__()
        self.lstm = nn.LSTM(
            n_channels,
            hidden,
            num_layers=n_lstm,
            batch_first=True,
            bidirectional=True,
            dropout=dropout if n_lstm > 1 else 0.0,
        )
        self.attention = AttentionPool(2 * hidden)
        self.drop = nn.Dropout(dropout)
        self.head = nn.Linear(2 * hidden, n_classes)

    def features(self, x: torch.Tensor) -> torch.Tensor:
        h, _ = self.lstm(x)
        return self.attention(h)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.drop(self.features(x)))
