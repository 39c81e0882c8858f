"""The search: a global stage, a local polish and profile likelihoods, each of whose
steps runs all its candidates as lanes of one batch.

* **Global**: a Latin hypercube over the bounds (``global_size`` candidates), then
  ``global_rounds`` rounds of the cross-entropy method: a normal distribution fitted to
  the best tenth is sampled anew. One batch per round; no candidate-by-candidate loop.
  Chosen over CMA-ES (the ``cma`` package) because a round of either is one batch here,
  and the cross-entropy update is ten lines that need no dependency.
* **Polish**: Levenberg–Marquardt from the best candidate, its Jacobian by central
  differences whose 2p columns run as lanes of one batch together with trial steps at
  several damping factors.
* **Profiles**: for each free input, a grid of values across its bounds (denser near
  the best fit); at each, the other inputs polished again, all grid points' Jacobian
  lanes in one batch per iteration. An input's 95 % interval is where its profile's
  chi-squared stays within 3.84 × max(1, reduced chi-squared) of the best (the factor
  widens the interval when the model fits worse than the noise); where the profile does
  not rise that far before a bound, the interval reaches the bound and the input is not
  determined on that side.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["Profile", "global_search", "polish", "profiles"]

Evaluate = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
"""Candidates (c, p) in the unit cube -> (chi2 (c,), scaled residuals (c, m))."""

STEP = 2e-3  # central-difference step in the unit cube
LAMBDAS = (1e-3, 1e-2, 1e-1, 1.0, 10.0)


def global_search(
    evaluate: Evaluate,
    p: int,
    rng: np.random.Generator,
    size: int,
    rounds: int,
    say: Callable[[str], None],
) -> tuple[np.ndarray, float, int]:
    """(best point, its chi2, evaluations)."""
    cube = (
        rng.permuted(np.tile(np.arange(size), (p, 1)), axis=1).T + rng.random((size, p))
    ) / size
    chi2, _ = evaluate(cube)
    points, values = cube, chi2
    say(f"global search: {size} candidates, best chi2 {np.min(chi2):.4g}")
    n = size
    for r in range(rounds):
        elite = points[np.argsort(values)[: max(p + 2, len(values) // 10)]]
        mean = elite.mean(axis=0)
        cov = np.cov(elite.T).reshape(p, p) + np.eye(p) * 1e-6
        sample = np.clip(rng.multivariate_normal(mean, cov, size // 2), 0.0, 1.0)
        chi2, _ = evaluate(sample)
        n += len(sample)
        points, values = np.vstack([points, sample]), np.concatenate([values, chi2])
        say(f"global search round {r + 1} of {rounds}: best chi2 {np.min(values):.4g}")
    best = int(np.argmin(values))
    return points[best], float(values[best]), n


def _jacobian_lanes(x: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points at x ± STEP along each free coordinate (an interior step one-sided near a
    bound) and their step sizes."""
    lanes, steps = [], []
    for k in np.flatnonzero(free):
        h = STEP
        plus, minus = x.copy(), x.copy()
        plus[k] = min(1.0, x[k] + h)
        minus[k] = max(0.0, x[k] - h)
        lanes += [plus, minus]
        steps.append(plus[k] - minus[k])
    return np.array(lanes), np.array(steps)


def _lm_step(r: np.ndarray, J: np.ndarray, lam: float) -> np.ndarray:
    A = J.T @ J
    return -np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), J.T @ r)


def polish(
    evaluate: Evaluate,
    starts: np.ndarray,
    free: np.ndarray,
    iterations: int = 12,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Levenberg–Marquardt from each of ``starts`` (s, p) at once, moving only the
    coordinates where ``free`` (s, p) is True. Returns (points, chi2, Jacobians at the
    points (s, m, p), evaluations)."""
    x = starts.copy()
    s, p = x.shape
    chi2, r = evaluate(x)
    n = s
    J = np.zeros((s, r.shape[1], p))
    for _ in range(iterations):
        lanes, steps = zip(*(_jacobian_lanes(x[i], free[i]) for i in range(s)))
        counts = [len(l) for l in lanes]
        _, rj = evaluate(np.vstack(lanes))
        n += len(rj)
        at = 0
        trials = []
        for i in range(s):
            cols = np.flatnonzero(free[i])
            diff = rj[at : at + counts[i]]
            at += counts[i]
            J[i] = 0.0
            J[i][:, cols] = ((diff[0::2] - diff[1::2]) / steps[i][:, None]).T
            for lam in LAMBDAS:
                step = np.zeros(p)
                step[cols] = _lm_step(r[i], J[i][:, cols], lam)
                trials.append(np.clip(x[i] + step, 0.0, 1.0))
        tchi2, tr = evaluate(np.array(trials))
        n += len(trials)
        moved = False
        for i in range(s):
            k = i * len(LAMBDAS) + int(
                np.argmin(tchi2[i * len(LAMBDAS) : (i + 1) * len(LAMBDAS)])
            )
            if tchi2[k] < chi2[i] * (1 - 1e-6):
                moved |= tchi2[k] < chi2[i] * (1 - 1e-4)
                x[i], chi2[i], r[i] = trials[k], tchi2[k], tr[k]
        if not moved:
            break
    return x, chi2, J, n


@dataclass(frozen=True)
class Profile:
    """The profile of one free input: its grid (unit cube), chi2 at each point with
    the others polished, and the 95 % interval in the unit cube with whether each end
    was found (False: the profile stays low up to that bound)."""

    grid: np.ndarray
    chi2: np.ndarray
    low: float
    high: float
    low_found: bool
    high_found: bool


def profiles(
    evaluate: Evaluate,
    best: np.ndarray,
    best_chi2: float,
    threshold: float,
    points: int,
    jacobian: np.ndarray,
) -> tuple[list[Profile], int, np.ndarray, float]:
    """The profile of every coordinate of ``best``, all grid points polished together:
    ``points`` across the bounds, and 12 within 3 times the half-width the
    ``jacobian`` at the best fit predicts (so that a narrow interval is resolved).
    Returns the profiles, the model runs, and the lowest point the profiles met with
    its chi2 (below ``best_chi2`` when ``best`` was not the best fit after all)."""
    p = len(best)
    cov = np.linalg.pinv(jacobian.T @ jacobian)
    half = np.sqrt(np.clip(np.diag(cov) * threshold, 0.0, None))
    grids = []
    for k in range(p):
        wide = np.linspace(0.0, 1.0, points)
        width = min(max(3.0 * half[k], 1e-4), 0.5)
        near = best[k] + width * np.linspace(-1.0, 1.0, 13)
        grids.append(np.unique(np.clip(np.concatenate([wide, near]), 0.0, 1.0)))
    starts, frees = [], []
    for k, grid in enumerate(grids):
        for g in grid:
            x = best.copy()
            x[k] = g
            free = np.ones(p, dtype=bool)
            free[k] = False
            starts.append(x)
            frees.append(free)
    starts_arr, frees_arr = np.array(starts), np.array(frees)
    if p > 1:
        ends, chi2, _, n = polish(evaluate, starts_arr, frees_arr, iterations=6)
    else:
        ends = starts_arr
        chi2, _ = evaluate(starts_arr)
        n = len(chi2)
    out, at = [], 0
    for k, grid in enumerate(grids):
        values = chi2[at : at + len(grid)]
        at += len(grid)
        out.append(_interval(grid, values, best[k], best_chi2, threshold))
    lowest = int(np.argmin(chi2))
    return out, n, ends[lowest], float(chi2[lowest])


def _interval(
    grid: np.ndarray, chi2: np.ndarray, best: float, best_chi2: float, threshold: float
) -> Profile:
    level = best_chi2 + threshold
    ends = []
    for side in (-1, 1):
        order = np.argsort(grid)[::side]  # away from the best fit
        xs = [g for g in grid[order] if (g - best) * side > 0]
        ys = [c for g, c in zip(grid[order], chi2[order]) if (g - best) * side > 0]
        prev_x, prev_y, found, end = best, best_chi2, False, (1.0 if side > 0 else 0.0)
        for x, y in zip(xs, ys):
            if y >= level:
                frac = (
                    (level - prev_y) / (y - prev_y)
                    if np.isfinite(y) and y > prev_y
                    else 0.0
                )
                end, found = prev_x + frac * (x - prev_x), True
                break
            prev_x, prev_y = x, y
        ends.append((end, found))
    (low, low_found), (high, high_found) = ends
    return Profile(grid, chi2, low, high, low_found, high_found)
