"""Re-selection of the dependent coordinates during a motion.

A planar five-bar (2 DOF) driven by one crank: the remaining DOF is a free
coordinate held fixed. With that coordinate held the linkage is a four-bar
that reaches a toggle within the crank turn; re-selecting the dependent
coordinates (a different joint becomes the held one) carries the sweep
through a full crank revolution, and without re-selection it fails.
"""

from __future__ import annotations

import numpy as np
from kin_models import five_bar

from pipeline.kinematics import assemble, closure, closure_residual, sweep
from pipeline.kinematics.drivers import Ramp


def Linear(v0, w):
    """Coordinate v0 + w t (t >= 0)."""
    return Ramp(t0=0.0, slope=w, v0=v0)


def _run(factor):
    m = five_bar()
    a = assemble(m, driven=["J1.theta"])
    t = np.linspace(0.0, 2 * np.pi, 721)
    return m, t, sweep(m, {"J1.theta": Linear(a.q[0], 1.0)}, t, a.q, reselect_factor=factor)


def test_reselection_carries_the_sweep_past_a_toggle():
    m, t, res = _run(10.0)
    assert res.success, res.message
    assert len(res.reselections) >= 1
    assert np.allclose(res["J1.theta"], res.q[0, 0] + t, atol=1e-14)
    assert max(np.abs(closure_residual(m, q)).max() for q in res.q) < 1e-11
    for k in range(0, t.size, 20):  # velocities satisfy J q' = 0 and one coordinate is held
        assert np.abs(closure(m, res.q[k]).J @ res.qd[k]).max() < 1e-12
        assert np.sum(np.abs(res.qd[k, 1:]) < 1e-14) == 1
    # rates equal central differences of the path to within the differences' own
    # truncation error h^2 |x'''| / 6 (x''' from differences of q''); the held
    # coordinate changes at a re-selection, so points next to one are skipped
    h = t[1] - t[0]
    fd = (res.q[2:] - res.q[:-2]) / (2 * h)
    d3 = np.abs(res.qdd[2:] - res.qdd[:-2]) / (2 * h)
    away = np.all(np.abs(t[1:-1, None] - np.array(res.reselections)[None]) > 1.5 * h, axis=1)
    bound = 1e-9 + 2.0 * h**2 * d3 / 6.0
    assert np.all((np.abs(res.qd[1:-1] - fd) <= bound)[away])


def test_without_reselection_the_toggle_stops_the_sweep():
    _, _, res = _run(np.inf)
    assert not res.success and res.reselections == ()
