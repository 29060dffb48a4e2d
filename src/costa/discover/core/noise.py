"""Measurement noise of densely sampled signals, estimated from the data themselves."""

from __future__ import annotations

import numpy as np

__all__ = ["estimate_noise"]


def estimate_noise(x: np.ndarray, inputs: np.ndarray | None = None) -> np.ndarray:
    """Measurement-noise std (C,) of each channel of ``x`` (..., T, C) from its second differences.

    For a smooth signal plus white noise of std s, the second difference has std
    s sqrt(6); the median absolute deviation ignores the few steps where an input
    impulse or a tapping makes the signal itself jump. Given ``inputs`` (..., T, 5), the
    second differences are taken net of the inputs' own (least squares): a channel that
    reads an input at once, as the pot voltage reads the line current, would otherwise
    count the input's step-to-step ripple as its noise.
    """
    second = np.diff(x, n=2, axis=-2).reshape(-1, x.shape[-1])
    if inputs is not None:
        driving = np.diff(inputs, n=2, axis=-2).reshape(-1, inputs.shape[-1])
        driving = driving[:, np.any(driving != 0.0, axis=0)]
        if driving.shape[1]:
            gains = np.linalg.lstsq(driving, second, rcond=None)[0]
            second = second - driving @ gains
    mad = np.median(np.abs(second - np.median(second, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(6)
