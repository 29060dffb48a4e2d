"""The compiled cell model against its own array code: the same numbers from the same operations,
derivatives that are derivatives, and rows that do not depend on the threads sharing them."""

from __future__ import annotations

import numpy as np
import pytest

from costa.compiled import CompiledModel, Parameters, compile_side_by_side
from costa.compiled.trace import Program, Row
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.sparse.observed import NOMINAL_STATE, PRIOR_STD
from costa.discover.sparse.shooting.screen import screen_terms
from costa.integrate import rk4_step
from costa.observe import observe
from costa.physics import ablated_model, true_model

CHANNELS = ("U_cell", "U_pot", "x6", "c2", "c3", "x5", "m_tap")


def _rows(rng, count: int, spread: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """States around a working cell and inputs with feeds, taps and the line current varying."""
    x = NOMINAL_STATE * (1 + spread * rng.standard_normal((count, 8)))
    x[:, 1] = rng.uniform(0.02, 0.05, count) * x[:, 1:4].sum(1)
    u = np.column_stack(
        [
            rng.uniform(0, 0.05, count),
            rng.uniform(1.2e5, 1.6e5, count),
            rng.uniform(0, 0.01, count),
            rng.uniform(0, 0.2, count),
            rng.uniform(0.04, 0.06, count),
        ]
    )
    return x, u


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300)))


@pytest.mark.parametrize("kind", ["true", "ablated", "part", "term", "transfer", "property", "input"])
def test_a_compiled_step_rounds_as_the_array_code(kind):
    """One RK4 step and the sensors of the true and ablated models, and of the true model corrected by
    the first hypothesis of each kind with its screen terms (coefficients per row), equal numpy's
    evaluation of the same model to the last bits: the same operations in the same order, and ``exp``
    and ``pow`` from the same C library (numpy's own vector versions on some CPUs differ in the last
    bit, hence not bit for bit here)."""
    rng = np.random.default_rng(3)
    x, u = _rows(rng, 256)
    model, parameters, values = (ablated_model() if kind == "ablated" else true_model()), [], []
    if kind not in ("true", "ablated"):
        hypothesis = next(h for h in candidate_hypotheses(model) if h.kind == kind)
        features = screen_terms(hypothesis)
        theta = Parameters(len(features))
        model, parameters = hypothesis.parametrised(model, features, theta), [theta]
        values = [1e-3 * rng.standard_normal((len(x), len(features)))]
    kernel = CompiledModel(model, 10.0, CHANNELS, parameters)
    for p, v in zip(parameters, values, strict=True):
        p.value = v
    with np.errstate(all="ignore"):
        step, sensed = rk4_step(model.rhs, x, u, 10.0), observe(model, x, u, CHANNELS)
    assert _relative(kernel.step(x, u, *values), step) <= 4e-16
    assert _relative(kernel.sense(x, u, *values), sensed) <= 4e-16


def test_tangents_are_the_derivatives_of_a_march():
    """A march's tangents in its start (scaled by the prior stds) and its coefficients match central
    differences of the march itself to the differences' own accuracy, over an hour of 10 s steps."""
    rng = np.random.default_rng(5)
    x, u = _rows(rng, 6, spread=0.01)
    x[:, 1] = rng.uniform(0.035, 0.045, len(x)) * x[:, 1:4].sum(1)  # an hour away from the alumina's pole
    u[:, 3] = 0.0  # no tap for an hour
    inputs = np.repeat(u[:, None], 360, 1)
    hypothesis = next(h for h in candidate_hypotheses(true_model()) if h.key == "part:bath_conductivity")
    features = screen_terms(hypothesis)[:3]
    theta = Parameters(len(features))
    kernel = CompiledModel(hypothesis.parametrised(true_model(), features, theta), 10.0, ("U_cell", "x6"), [theta])
    values = 1e-3 * rng.standard_normal((len(x), len(features)))
    directions = 8 + len(features)
    dx, dp = np.zeros((len(x), 8, directions)), np.zeros((len(x), len(features), directions))
    dx[:, np.arange(8), np.arange(8)] = PRIOR_STD
    dp[:, np.arange(len(features)), 8 + np.arange(len(features))] = 1.0
    out, dout, end, dend = kernel.march_tangents(x, inputs, values, dx, dp)
    assert np.isfinite(dend).all() and np.isfinite(dout).all()
    np.testing.assert_array_equal(end, kernel.march(x, inputs, values)[1])
    for j in range(directions):
        h = 1e-5
        moved_x, moved_p = (h * dx[..., j], h * dp[..., j])
        plus, minus = (kernel.march(x + s * moved_x, inputs, values + s * moved_p) for s in (1, -1))
        central = (plus[1] - minus[1]) / (2 * h)
        assert np.max(np.abs(dend[..., j] - central)) <= 1e-6 * np.max(np.abs(central)) + 1e-12
        central = (plus[0] - minus[0]) / (2 * h)
        assert np.max(np.abs(dout[..., j] - central)) <= 1e-6 * np.max(np.abs(central)) + 1e-12


def test_rows_do_not_depend_on_the_threads_sharing_them(monkeypatch):
    rng = np.random.default_rng(7)
    x, u = _rows(rng, 37)
    inputs = np.repeat(u[:, None], 50, 1)
    results = []
    for threads in ("1", "3"):
        monkeypatch.setenv("OMP_NUM_THREADS", threads)
        kernel = CompiledModel(true_model(), 10.0, ("U_cell", "x6"))
        channels, _ = kernel.march(x, inputs)
        y = np.where(np.arange(50)[None, :, None] % 4 == 0, channels, np.nan)
        smoothed = kernel.smooth(y, inputs, x, np.diag(PRIOR_STD**2), 1e-7 * NOMINAL_STATE, np.array([0.005, 1.5]))
        results.append((channels, smoothed.mean, smoothed.log_likelihood))
    for one, three in zip(*results, strict=True):
        np.testing.assert_array_equal(one, three)


def test_a_model_that_reads_an_array_it_was_not_given_is_refused():
    """A correction read from a numpy array at evaluation time (not a :class:`Parameters`) cannot be
    compiled: one error says so, instead of a kernel that silently ignores it."""
    hypothesis = next(h for h in candidate_hypotheses(true_model()) if h.key == "term:bath_energy")
    shifted = hypothesis.shifted(true_model(), np.zeros(10))
    with pytest.raises(TypeError, match="only numbers and the row's states, inputs and parameters"):
        CompiledModel(shifted, 10.0)


def test_a_missing_compiler_is_named(monkeypatch, tmp_path):
    monkeypatch.setenv("COSTA_KERNEL_CACHE", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    with pytest.raises(RuntimeError, match="found no C compiler"):
        CompiledModel(true_model(), 10.0)


def test_operations_are_written_once_and_unused_ones_dropped():
    program = Program(["a", "b"])
    a, b = program.symbol("a"), program.symbol("b")
    first, again = a * b, a * b
    unused = a + b  # noqa: F841
    assert first.name == again.name
    assert [op.name for op in program.pruned(Row([first]).items).operations] == [first.name]


def test_models_compiled_side_by_side_step_as_each_compiled_alone(monkeypatch, tmp_path):
    """Traced now, compiled later on two threads at once: the libraries land in the cache and the steps
    are those of the same models compiled as they are made."""
    monkeypatch.setenv("COSTA_KERNEL_CACHE", str(tmp_path))
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    models = [true_model(), ablated_model()]
    later = [CompiledModel(m, 10.0, ("U_cell", "x6"), derivatives=False, compiled=False) for m in models]
    assert not list(tmp_path.glob("*.so"))
    compile_side_by_side(later)
    assert len(list(tmp_path.glob("*.so"))) == 2
    x, u = _rows(np.random.default_rng(2), 4, spread=0.01)
    for model, kernel in zip(models, later, strict=True):
        np.testing.assert_array_equal(kernel.step(x, u), CompiledModel(model, 10.0, derivatives=False).step(x, u))
