"""Transient dynamics: :func:`simulate` (DESIGN §4).

Two formulations of closed loops (``formulation``):

* ``"dae"`` (default for closed loops and for ``generalized_alpha``): every coordinate (joint and modal) with
  Lagrange multipliers for every closure row, M q'' + C^T lambda = rhs, c(q) = 0. Redundant
  rows and singular positions need no choice of coordinates; the branch comes from
  continuity of all coordinates. ``generalized_alpha`` integrates it at index 3
  (:mod:`pipeline.solver.index3`; fixed ``step`` or adaptive); the scipy methods integrate its
  index-1 form with coordinate projection after every step (:mod:`pipeline.solver.projected`).
* ``"partitioned"`` (the seed's method; default for open chains with the scipy methods):
  independent coordinates only, the dependent ones closed by position analysis at every
  evaluation
  (:mod:`pipeline.solver.integrate`); it needs a regular dependent block, so it stops at a
  singular position and re-selects coordinates near one.

``INTEGRATORS`` maps a method name to a scipy ``OdeSolver`` class:

* ``"DOP853"`` (default): explicit 8th-order Runge-Kutta, the accurate choice for smooth runs.
* ``"Radau"``, ``"BDF"``: implicit, for stiff runs with high-frequency modes.
* ``"RK45"``, ``"LSODA"``: also available.
* ``"generalized_alpha"``: second order, implicit, damping the highest modes by ``rho_inf``;
  for flexible closed loops whose ~kHz closed-loop modes nobody needs resolved.

Every result is checked (:mod:`pipeline.solver.monitors`): energy balance, closure,
deformation range, step size; ``result.verdict`` is "ok", "suspect" (it finished but a check
tripped: the message says which, when and by how much) or "partial" (it stopped).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK45, Radau

from pipeline.core.errors import ConfigError
from pipeline.solver.generalized_alpha import GeneralizedAlpha, coefficients
from pipeline.solver.monitors import Limits, judge
from pipeline.solver.result import ENERGY_KEYS, SimulationResult

__all__ = ["ENERGY_KEYS", "FORMULATIONS", "INTEGRATORS", "Limits", "SimulationResult",
           "simulate"]

INTEGRATORS = {"DOP853": DOP853, "Radau": Radau, "BDF": BDF, "RK45": RK45, "LSODA": LSODA,
               "generalized_alpha": GeneralizedAlpha}
FORMULATIONS = ("auto", "dae", "partitioned")


def simulate(system, q0, qd0, t_span, t_eval=None, method: str = "DOP853", rtol: float = 1e-8,
             atol: float = 1e-10, progress: bool = True,
             max_step: float = np.inf, step: float | None = None,
             rho_inf: float = 0.8, formulation: str = "auto",
             max_steps: int = 1_000_000, max_wall: float | None = None,
             limits: Limits | None = None, error_estimate: bool = True) -> SimulationResult:
    """Transient dynamics of ``system`` from (q0, qd0) over ``t_span``.

    Parameters
    ----------
    system : pipeline.dynamics.System.
    q0 : (n,) initial coordinates, assembled (``pipeline.kinematics.initial_positions``);
        an unclosed q0 is moved onto the loops by the least change (logged).
    qd0 : (n,) initial rates. Every nonzero entry is a given rate and is honoured (the
        others follow from the loops, modal rates staying zero where they can); a set that
        the loops cannot honour is a ConfigError naming the rates (never silently dropped).
    t_span : (t0, t1) s.
    t_eval : (k,) increasing output times in t_span (default 101 points).
    method : key of ``INTEGRATORS``.
    rtol, atol : tolerances (local error; atol in the coordinates' natural units for the
        DAE: rad, the length scale, a modal amplitude moving a frame by it).
    progress : show a progress bar on an interactive terminal.
    max_step : largest step, s (adaptive methods).
    step : fixed step, s (``generalized_alpha``; required with the partitioned formulation,
        adaptive in the DAE formulation when None).
    rho_inf : spectral radius at infinite frequency, [0, 1] (``generalized_alpha``).
    formulation : "auto" (DAE for closed loops and for ``generalized_alpha``, partitioned
        for open chains with the scipy methods), "dae" or "partitioned".
    max_steps, max_wall : budgets (steps; wall-clock seconds); a run that exhausts one stops
        with its partial history.
    limits : thresholds of the trust checks (default :class:`Limits()`).
    error_estimate : a fixed-step ``generalized_alpha`` run in the DAE formulation is run
        again at twice the step to estimate its error against rtol/atol
        (:mod:`pipeline.solver.step_error`; about half the run's cost again). False skips
        it (a timing comparison with a code that does not estimate): the verdict then says
        nothing of the integration error.

    Returns
    -------
    SimulationResult
        ``verdict`` "ok", "suspect" or "partial" with a message; bad arguments raise
        ConfigError instead.

    Examples
    --------
    >>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
    >>> from pipeline.dynamics import BodyMass, System
    >>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
    ...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
    >>> s = System(mech, {"arm": BodyMass.rigid(1.0, [1.0, 0, 0], np.zeros((3, 3)))},
    ...            gravity=[0.0, -9.81, 0.0])
    >>> r = simulate(s, np.zeros(1), np.zeros(1), (0.0, 0.5), progress=False)
    >>> r.verdict, bool(abs(r.energies["total"]).max() < 1e-6)
    ('ok', True)
    """
    from pipeline.solver.integrate import check_arguments, run
    from pipeline.solver.start import consistent_start

    if isinstance(method, str):
        if method not in INTEGRATORS:
            raise ConfigError(f"simulate: method: expected one of {sorted(INTEGRATORS)}, "
                              f"got {method!r}")
        cls, name = INTEGRATORS[method], method
    else:
        cls, name = method, getattr(method, "__name__", str(method))
    if formulation not in FORMULATIONS:
        raise ConfigError(f"simulate: formulation: expected one of {list(FORMULATIONS)}, "
                          f"got {formulation!r}")
    if not (isinstance(max_steps, int | np.integer) and max_steps > 0):
        raise ConfigError(f"simulate: max_steps: expected a positive integer, got {max_steps!r}")
    if max_wall is not None and not (np.isfinite(max_wall) and max_wall > 0):
        raise ConfigError(f"simulate: max_wall: expected seconds > 0, got {max_wall!r}")
    loops = bool(system.mechanism.topology.loops)
    second_order = getattr(cls, "SECOND_ORDER", False)
    if formulation == "auto":
        # generalised-alpha on an open chain too: its compiled step is ~20x faster than the
        # partitioned step with the same states (docs/closed_loops.md, "Speed")
        formulation = "dae" if loops or second_order else "partitioned"
    if step is not None and not (np.isfinite(step) and step > 0):
        raise ConfigError(f"simulate: step: expected a fixed step > 0 s, got {step!r}")
    if system.state_slices and not (second_order and formulation == "dae"):
        raise ConfigError(
            f"simulate: force element(s) {[f.name for f, _ in system.state_slices]} have "
            f"states of their own (hydraulic pressures, ...), which only method="
            f"'generalized_alpha' in the DAE formulation integrates; got method={name!r}, "
            f"formulation={formulation!r}")
    if second_order:
        coefficients(rho_inf)  # validates rho_inf before any work
        if formulation == "partitioned" and step is None:
            raise ConfigError(f"simulate: step: method {name!r} with the partitioned "
                              "formulation needs a fixed step > 0 s")
    q0, qd0, t0, t1, te = check_arguments(system, q0, qd0, t_span, t_eval, rtol, atol)
    q0, qd0 = consistent_start(system, q0, qd0, t0)
    if system.state_slices:
        system.initial_states(q0, t0)  # a held state that cannot hold: ConfigError, now
    budget = {"max_steps": int(max_steps), "max_wall": max_wall}
    if formulation == "dae":
        if second_order:
            from pipeline.solver.dae import run_dae

            r = run_dae(system, q0, qd0, t0, t1, te, rtol=rtol, atol=atol, step=step,
                        rho_inf=rho_inf, max_step=max_step, progress=progress,
                        estimate=error_estimate, **budget)
        else:
            from pipeline.solver.projected import run_projected

            r = run_projected(system, q0, qd0, t0, t1, te, cls, name, rtol=rtol, atol=atol,
                              max_step=max_step, progress=progress, **budget)
    else:
        options = {"step": float(step), "rho_inf": float(rho_inf)} if second_order else None
        r = run(system, q0, qd0, t0, t1, te, cls, name, rtol, atol, progress, max_step,
                options, **budget)
    return judge(system, r, limits or Limits(), t_span=(t0, t1))
