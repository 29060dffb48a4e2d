"""Compiled kernels of a cell model: its RK4 step, its sensors and their derivatives, an extended
Kalman smoother over them, traced from the model's own array code (:mod:`.trace`) and compiled to
C for batches of rows (:mod:`.kernel`)."""

from .kernel import CompiledModel, CompiledSystem, Parameters, Smoothed, compile_side_by_side, kernel_cache

__all__ = ["CompiledModel", "CompiledSystem", "Parameters", "Smoothed", "compile_side_by_side", "kernel_cache"]
