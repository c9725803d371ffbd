"""The public API imports nothing heavy until a name is used, and every name it lists
resolves to its home module's object."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("numpy", "scipy", "numba", "gmsh", "skfem", "pyvista", "matplotlib", "dask")


def test_importing_the_api_loads_no_numerical_library():
    code = ("import sys, pipeline.api\n"
            f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "", out.stdout


def test_every_public_name_resolves_to_its_home():
    import importlib

    from pipeline import api

    for name in api.__all__:
        value = getattr(api, name)
        home = api._HOMES.get(name)
        if home is not None:
            assert value is getattr(importlib.import_module(home), name), name
    assert sorted(dir(api)) == sorted(api.__all__)
    try:
        api.no_such_name  # noqa: B018
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:  # pragma: no cover
        raise AssertionError("an unknown name resolved")
