"""Front-end loader with a flexible lift arm and a flexible lower link (coarse
reduced plates, gmsh + scikit-fem), 0.1 s of the lift: the loops stay closed
and the energy balance T + V_gravity + V_elastic + V_load + E_dissipated - W_drivers
is constant (V_load = -F . R_LOAD is the load's work with the sign flipped)."""

from __future__ import annotations

import numpy as np
import pytest
from loader_flex_model import build_flexible_loader, reduce_links

from pipeline.solver import simulate

T_END = 0.1


@pytest.fixture(scope="module")
def loader(tmp_path_factory):
    reduced = reduce_links(tmp_path_factory.mktemp("loader_links"), arm_size=0.05,
                           link_size=0.03)
    return build_flexible_loader(reduced)


@pytest.fixture(scope="module", params=["dae", "partitioned"])
def run(loader, request):
    system, q0 = loader
    t = np.linspace(0.0, T_END, 11)
    r = simulate(system, q0, np.zeros_like(q0), (0.0, T_END), t, rtol=1e-8, atol=1e-8,
                 progress=False, formulation=request.param)
    assert r.formulation == request.param
    return system, r


@pytest.mark.gmsh
def test_flexible_loader_closes_and_balances_energy(run):
    _system, r = run
    assert r.success, r.message
    assert set(r.driven) == {"LCYL.d", "TCYL.d", "CHASSIS_X.d"}
    assert r.closure_residual.max() < 1e-10
    e = r.energies
    # gravity and the load on the undeformed start excite the modes
    eta = np.array([r.coordinate(c) for c in r.coordinates if ".eta" in c])
    assert eta.shape[0] == 3 and np.abs(eta).max() > 1e-4
    assert e["elastic"].max() > 1e-3 and e["dissipated"][-1] > 0.0
    # scale: the variations of the energy terms (independent of the potential datum)
    scale = sum(np.ptp(e[k]) for k in ("kinetic", "gravity", "elastic", "forces",
                                       "dissipated", "driver_work"))
    drift = np.abs(e["total"] - e["total"][0]).max()
    print(f"\nflexible loader {T_END} s: steps {r.n_steps}, rhs {r.n_rhs}, closure "
          f"{r.closure_residual.max():.1e}, energy drift {drift:.2e} J of {scale:.3g} J")
    assert drift < 1e-6 * scale


@pytest.mark.gmsh
def test_wrong_load_energy_breaks_balance(run):
    """The balance sees the load: dropping its potential leaves its work unaccounted."""
    _system, r = run
    e = r.energies
    total = e["total"] - e["forces"]
    assert np.abs(total - total[0]).max() > 1e3 * max(np.abs(e["total"] - e["total"][0]).max(),
                                                      1e-12)

