"""Measurement noise of densely sampled signals, estimated from the data themselves."""

from __future__ import annotations

import numpy as np

__all__ = ["estimate_noise"]


def estimate_noise(x: np.ndarray) -> np.ndarray:
    """Measurement-noise std (8,) of each state from its second differences.

    For a smooth signal plus white noise of std s, the second difference has std
    s sqrt(6); the median absolute deviation ignores the few steps where an input
    impulse or a tapping makes the signal itself jump.
    """
    second = np.diff(x, n=2, axis=-2).reshape(-1, x.shape[-1])
    mad = np.median(np.abs(second - np.median(second, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(6)
