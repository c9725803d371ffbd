"""Shared pytest configuration."""

import importlib.util
import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


def pytest_collection_modifyitems(config, items):
    if importlib.util.find_spec("gmsh") is None:
        skip = pytest.mark.skip(reason="gmsh not installed (pip install .[mesh])")
        for item in items:
            if "gmsh" in item.keywords:
                item.add_marker(skip)


@pytest.fixture(autouse=True)
def _own_link_cache(tmp_path, monkeypatch):
    """Each test's commands use a link cache of its own (the shared default, output/links
    under the current folder, would be the repository's)."""
    monkeypatch.setenv("FLEXMECH_LINKS", str(tmp_path / "link-cache"))
