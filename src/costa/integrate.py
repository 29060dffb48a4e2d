"""Fixed-step integrators for dx/dt = f(x, u) with u held over the step."""

from __future__ import annotations

from collections.abc import Callable

from .physics.cell import Array

RightHandSide = Callable[[Array, Array], Array]


def rk4_step(f: RightHandSide, x: Array, u: Array, dt: float) -> Array:
    """One classical Runge-Kutta step of length ``dt`` [s]."""
    k1 = f(x, u)
    k2 = f(x + (dt / 2) * k1, u)
    k3 = f(x + (dt / 2) * k2, u)
    k4 = f(x + dt * k3, u)
    return x + (dt / 6) * (k1 + 2 * k2 + 2 * k3 + k4)


def euler_step(f: RightHandSide, x: Array, u: Array, dt: float) -> Array:
    """One forward-Euler step of length ``dt`` [s]."""
    return x + dt * f(x, u)


STEPPERS = {"rk4": rk4_step, "euler": euler_step}
