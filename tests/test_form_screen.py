"""The screen of every hypothesis' closed forms, linearised at the uncorrected model's shooting fit."""

from __future__ import annotations

import numpy as np

from costa.discover.sparse.form_screen import states_eliminated


def test_the_reduced_gradient_gives_what_the_coefficients_add_to_the_whole_least_squares_fit():
    """For a linear least-squares problem in each cell's states z_i and shared coefficients t,
    min sum_i |r_i + J_i z_i + K_i t|^2, hr' S^-1 hr is the fit's reduction with z and t free
    less its reduction with z alone, each from the projection onto the columns."""
    rng = np.random.default_rng(1)
    n, rows, size, terms = 3, 50, 12, 2
    j = rng.normal(size=(n, rows, size))
    k = rng.normal(size=(n, rows, terms))
    r = rng.normal(size=(n, rows))
    a, b = np.einsum("nri,nrj->nij", j, j), np.einsum("nri,nrp->nip", j, k)
    c, g, h = np.einsum("nrp,nrq->pq", k, k), np.einsum("nri,nr->ni", j, r), np.einsum("nrp,nr->p", k, r)
    schur, reduced, _, _ = states_eliminated(a, b, g, c, h)

    def reduction(columns: np.ndarray) -> float:
        fitted = columns @ np.linalg.lstsq(columns, r.reshape(-1), rcond=None)[0]
        return float(fitted @ fitted)

    whole = np.zeros((n * rows, n * size + terms))
    for i in range(n):
        whole[i * rows : (i + 1) * rows, i * size : (i + 1) * size] = j[i]
        whole[i * rows : (i + 1) * rows, n * size :] = k[i]
    added = reduction(whole) - reduction(whole[:, : n * size])
    np.testing.assert_allclose(reduced @ np.linalg.solve(schur, reduced), added, rtol=1e-9)
