"""Transient dynamics: integrators and :func:`simulate` (DESIGN §4).

``INTEGRATORS`` maps a name to a scipy ``OdeSolver`` class:

* ``"DOP853"`` (default): explicit 8th-order Runge-Kutta, the accurate choice
  for smooth runs and tight tolerances (energy-conservation tests).
* ``"Radau"``: implicit, L-stable 5th order, for stiff runs with
  high-frequency modes (step size not limited by the highest mode).
* ``"BDF"``, ``"RK45"``, ``"LSODA"``: also available.
* ``"generalized_alpha"``: fixed-step, second-order, implicit with numerical damping of
  the highest modes (``rho_inf``); for closed loops whose stiff closed-loop modes cap an
  explicit step (:mod:`pipeline.solver.generalized_alpha`). Needs ``step``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK45, Radau

from pipeline.core.errors import ConfigError
from pipeline.solver.generalized_alpha import GeneralizedAlpha, coefficients
from pipeline.solver.integrate import run
from pipeline.solver.result import ENERGY_KEYS, SimulationResult

__all__ = ["ENERGY_KEYS", "INTEGRATORS", "SimulationResult", "simulate"]

INTEGRATORS = {"DOP853": DOP853, "Radau": Radau, "BDF": BDF, "RK45": RK45, "LSODA": LSODA,
               "generalized_alpha": GeneralizedAlpha}


def simulate(system, q0, qd0, t_span, t_eval=None, method: str = "DOP853", rtol: float = 1e-8,
             atol: float = 1e-10, progress: bool = True,
             max_step: float = np.inf, step: float | None = None,
             rho_inf: float = 0.8) -> SimulationResult:
    """Transient dynamics of ``system`` from (q0, qd0) over ``t_span``.

    Parameters
    ----------
    system : pipeline.dynamics.System.
    q0 : (n,) assembled initial coordinates (dependent ones are re-closed).
    qd0 : (n,) initial rates; only the independent entries (modal, free) are
        used, the dependent ones follow from the loops.
    t_span : (t0, t1) s.
    t_eval : (k,) increasing output times in t_span (default 101 points).
    method : key of ``INTEGRATORS`` or an ``OdeSolver`` subclass.
    rtol, atol : integrator tolerances.
    progress : show a progress bar on an interactive terminal.
    max_step : largest step, s (adaptive methods).
    step : fixed step, s (``generalized_alpha``; required there).
    rho_inf : spectral radius at infinite frequency, [0, 1] (``generalized_alpha``).

    Returns
    -------
    SimulationResult
        ``success`` False with the partial history and a message if the
        integration failed; bad arguments raise ConfigError instead.

    Examples
    --------
    >>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
    >>> from pipeline.dynamics import BodyMass, System
    >>> mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
    ...                        [Joint("pin", "revolute", "ground", "body", "arm", "body")])
    >>> s = System(mech, {"arm": BodyMass.rigid(1.0, [1.0, 0, 0], np.zeros((3, 3)))},
    ...            gravity=[0.0, -9.81, 0.0])
    >>> r = simulate(s, np.zeros(1), np.zeros(1), (0.0, 0.5), progress=False)
    >>> r.success, bool(abs(r.energies["total"]).max() < 1e-6)
    (True, True)
    """
    if isinstance(method, str):
        if method not in INTEGRATORS:
            raise ConfigError(f"simulate: method: expected one of {sorted(INTEGRATORS)}, "
                              f"got {method!r}")
        cls, name = INTEGRATORS[method], method
    else:
        cls, name = method, getattr(method, "__name__", str(method))
    options = None
    if getattr(cls, "SECOND_ORDER", False):
        if step is None or not np.isfinite(step) or step <= 0:
            raise ConfigError(f"simulate: step: method {name!r} needs a fixed step > 0 s, "
                              f"got {step!r}")
        options = {"step": float(step), "rho_inf": float(rho_inf)}
        coefficients(rho_inf)  # validates rho_inf before any work
    return run(system, q0, qd0, t_span, t_eval, cls, name, rtol, atol, progress, max_step,
               options)
