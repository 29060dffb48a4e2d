"""Partial, sparse measurements as the estimator reads them: the channels, their noise, the first state's prior."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ...physics import CellModel
from ..core.noise import estimate_noise
from .observed import SETTLE_S, prior, searched_start, start_is_searched

__all__ = ["Observations", "channel_noise"]


@dataclass(frozen=True)
class Observations:
    """Measured channels y (n, K, C) (NaN: not sampled), inputs u (n, K, 5), noise std (C,), step dt [s];
    ``start`` (n, 8): the prior mean of each first state where it was searched (:meth:`with_start`)."""

    y: np.ndarray
    u: np.ndarray
    channels: tuple[str, ...]
    noise: np.ndarray
    dt: float
    start: np.ndarray | None = None

    def subset(self, trajectories: np.ndarray | slice) -> Observations:
        start = None if self.start is None else self.start[trajectories]
        return Observations(
            y=self.y[trajectories],
            u=self.u[trajectories],
            channels=self.channels,
            noise=self.noise,
            dt=self.dt,
            start=start,
        )

    def steps(self, begin: int, end: int) -> Observations:
        """Steps [begin, end) of every cell, their first state not yet searched."""
        return Observations(
            y=self.y[:, begin:end], u=self.u[:, begin:end], channels=self.channels, noise=self.noise, dt=self.dt
        )

    def with_start(self, model: CellModel) -> Observations:
        """These observations with each first state searched under ``model`` where one voltage
        sample cannot place it (:func:`.observed.searched_start`)."""
        start = searched_start(model, self.y, u=self.u, channels=self.channels, noise_std=self.noise, dt=self.dt)
        return dataclasses.replace(self, start=start)

    def searched_again(self, model: CellModel) -> Observations:
        """These observations with each first state searched under ``model`` where it was searched
        at all: a corrected model is scored from the start it would place the cell at itself, as the
        uncorrected one was (a start chosen under a model without the effect derails the right
        model's filter: the liquidus case's true model loses 3.8e6 of log-likelihood from it)."""
        return self if self.start is None else self.with_start(model)

    @property
    def settling_steps(self) -> int:
        """The first steps whose innovations the channel tests leave out: those of :data:`.observed.SETTLE_S`
        where the first state is searched, none where the first samples place it."""
        return round(SETTLE_S / self.dt) if start_is_searched(self.y, self.channels) else 0

    def prior(self) -> tuple[np.ndarray, np.ndarray]:
        """Prior mean (n, 8) and covariance (8, 8) of the first state."""
        return prior(self.y, self.channels, self.start)


def channel_noise(
    y: np.ndarray, channels: Sequence[str], declared: Mapping[str, float], inputs: np.ndarray | None = None
) -> np.ndarray:
    """Noise std per channel (C,): estimated from second differences (net of the ``inputs``' (n, T, 5)
    where given) where a channel is sampled at every step, else the declared sensor noise (a channel
    sampled hours apart cannot tell its noise from the process)."""
    noise = []
    for c, name in enumerate(channels):
        values = y[..., c]
        if np.isfinite(values).all():
            noise.append(float(estimate_noise(values[..., None], inputs)[0]))
        elif name in declared:
            noise.append(float(declared[name]))
        else:
            raise ValueError(
                f"channel {name!r} is not sampled at every step, so its noise cannot be estimated from the data; "
                "declare it in discovery.user_data.noise (the sensor's noise std, in the channel's unit)"
            )
    return np.array(noise)
