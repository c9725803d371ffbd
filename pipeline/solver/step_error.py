"""The error of a fixed-step run, estimated by running it again at twice the step.

A fixed step has no error control, so a run at too coarse a step used to end ``ok`` with
any error (a heavy top's precession 19 % fast at 1 ms). After the run, the same motion is
integrated with the step 2h (half the steps: half the run's cost again) and the two
histories are compared at the outputs. For a method of order p the error of the h run is
|q_h - q_2h| / (2^p - 1); it is taken as |q_h - q_2h| itself (p = 1), since index-3
generalised-alpha keeps its second order only where Newton, the start and the motion let
it (a spinning top converges at first order or worse; see docs/closed_loops.md): the
estimate is then conservative where the method behaves, and still of the right size where
it does not. Windows of a few steps at h and h/2 were tried first and extrapolated
linearly in time: they missed the top's error by 30x, whose precession error grows
faster than linearly.

The tolerance is the user's: ``atol`` in each coordinate's unit plus ``rtol`` times the
coordinate's largest magnitude over the run -- for a link's modal coordinates, the largest
of all its modal coordinates (a high mode's tiny amplitude is no scale for its error: the
link's deformation is).
"""

from __future__ import annotations

import numpy as np

from pipeline.solver.result import SimulationResult


def fixed_step_error(r: SimulationResult, coarse: SimulationResult, U: np.ndarray,
                     rtol: float, atol: float, unit: np.ndarray, modal_index=(),
                     state_scales=None) -> dict:
    """Estimate of the error of the fixed-step run ``r`` from ``coarse``, the same run at
    twice the step, compared at their common outputs (the integrated coordinates U;
    ``modal_index``: each link's modal coordinates, ``Mechanism.modal_index``), and the
    force elements' own states (``r.states``; their tolerance: atol times
    ``state_scales`` (nz,) plus rtol times their largest magnitude).

    Returns
    -------
    {"error_ratio": estimated error over the tolerance, largest over outputs and
    coordinates (1: at the tolerance), "error_coordinate": its name, "error_time": when,
    s}, or {"error_unavailable": why} when the run at twice the step did not finish (the
    run is then not known to be within its tolerance, and the checks say so).
    """
    k = min(r.t.size, coarse.t.size)
    if not coarse.success:
        return {"error_unavailable": f"the run at twice the step failed: {coarse.message}"}
    if k == 0 or not np.allclose(r.t[:k], coarse.t[:k]):
        return {"error_unavailable": "the run at twice the step has other output times"}
    out = scaled_error(r, np.abs(r.q[:k] - coarse.q[:k]), U, rtol, atol, unit, modal_index)
    if r.states.size and state_scales is not None:
        out = with_state_error(out, r, np.abs(r.states[:k] - coarse.states[:k]), rtol, atol,
                               state_scales)
    return out


def state_tolerance(size: np.ndarray, rtol: float, atol: float, state_scales) -> np.ndarray:
    """(nz,) the error accepted in each element state: atol times its scale (its unit's
    meaningful change) plus rtol times ``size``, its largest magnitude over the run."""
    return atol * np.asarray(state_scales, dtype=float) + rtol * np.asarray(size, dtype=float)


def with_state_error(out: dict, r: SimulationResult, deviation: np.ndarray, rtol: float,
                     atol: float, state_scales) -> dict:
    """``out`` (:func:`scaled_error`'s) or, where an element state's estimated error
    ``deviation`` (k, nz) is the larger over its tolerance, that state's figures."""
    if not deviation.size:
        return out
    scaled = deviation / state_tolerance(np.abs(r.states).max(axis=0), rtol, atol,
                                         state_scales)
    i, j = np.unravel_index(int(np.argmax(scaled)), scaled.shape)
    if not scaled[i, j] <= out["error_ratio"]:  # NaN too
        return {"error_ratio": float(scaled[i, j]), "error_coordinate": r.state_names[j],
                "error_time": float(r.t[i])}
    return out


def tolerance(size: np.ndarray, U: np.ndarray, rtol: float, atol: float, unit: np.ndarray,
              modal_index=()) -> np.ndarray:
    """(len(U),) the error accepted in each integrated coordinate: atol in its unit plus
    rtol times ``size`` (n,), its largest magnitude over the run (module docstring)."""
    size = np.array(size, dtype=float)
    for idx in modal_index:  # a link's modes share its deformation's scale
        if len(idx):
            size[idx] = size[idx].max()
    return atol * unit[U] + rtol * size[U]


def scaled_error(r: SimulationResult, deviation: np.ndarray, U: np.ndarray, rtol: float,
                 atol: float, unit: np.ndarray, modal_index=()) -> dict:
    """The estimated error ``deviation`` (k, n) of the first k outputs of ``r`` against
    the user's tolerance (module docstring): {"error_ratio", "error_coordinate",
    "error_time"} as :func:`fixed_step_error`."""
    scaled = deviation[:, U] / tolerance(np.abs(r.q).max(axis=0), U, rtol, atol, unit,
                                         modal_index)
    if not np.all(np.isfinite(scaled)):
        return {"error_ratio": np.inf, "error_coordinate": "", "error_time": float(r.t[-1])}
    if not scaled.size:  # every coordinate driven: only element states are integrated
        return {"error_ratio": 0.0, "error_coordinate": "", "error_time": float(r.t[0])}
    i, j = np.unravel_index(int(np.argmax(scaled)), scaled.shape)
    return {"error_ratio": float(scaled[i, j]),
            "error_coordinate": r.coordinates[int(U[j])], "error_time": float(r.t[i])}
