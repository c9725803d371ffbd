"""One grammar for a marker's position component in a signal name (a controller's measured
signal, a co-simulation input, a workflow series): pipeline.kinematics.marker_names."""

import re

import pytest

from pipeline.kinematics.marker_names import MarkerComponent, marker_component


@pytest.mark.parametrize("text, kw, parts", [
    ("boom.tip:x", {}, ("boom", "tip", 0, None)),
    ("boom.tip:z", {}, ("boom", "tip", 2, None)),
    ("boom.tip", {"norm": True}, ("boom", "tip", None, None)),
    ("boom.tip:norm", {"norm": True}, ("boom", "tip", None, None)),
    ("boom.tip:y@arm", {"norm": True, "axes": True}, ("boom", "tip", 1, "arm")),
    ("boom.tip:y@ground", {"axes": True}, ("boom", "tip", 1, None)),
    ("boom.a.b:y", {}, ("boom", "a.b", 1, None)),  # a frame's name may hold a dot
])
def test_the_parts_of_a_marker_component(text, kw, parts):
    assert marker_component(text, **kw) == MarkerComponent(*parts)


@pytest.mark.parametrize("text, kw", [
    ("boom.tip:w", {}), ("boomtip:y", {}), (".tip:y", {}), ("boom.:y", {}),
    ("boom.tip", {}), ("boom.tip:norm", {}), ("boom.tip:y@arm", {}),
    ("boom.tip:y@", {"axes": True}), ("boom.tip:q", {"norm": True, "axes": True}),
])
def test_a_malformed_name_says_what_was_expected(text, kw):
    with pytest.raises(ValueError, match=re.escape("expected 'link.frame:x|y|z") + ".*got "
                       + re.escape(repr(text))):
        marker_component(text, **kw)
