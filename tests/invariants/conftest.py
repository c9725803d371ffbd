"""Small link specs reduced once per session (gmsh + scikit-fem)."""

import pytest
from link_samples import write_bar


@pytest.fixture(scope="session")
def bar_link(tmp_path_factory):
    """(spec path, ReducedLink) of a small steel-free Al bar, reduced once."""
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    folder = tmp_path_factory.mktemp("bar")
    path = write_bar(folder)
    link, status = reduce_spec(load_link_spec(path), folder, folder / "links")
    assert status == "miss"
    return path, link
