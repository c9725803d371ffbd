"""Stages: timed and logged once, also when a library step that times itself is timed
again by its caller under the same name (meshing inside a link's reduction)."""

from __future__ import annotations

import logging

from pipeline.core.progress import StageTimes, stage


def _logged(caplog) -> list[str]:
    return [r.getMessage().split(":")[0] for r in caplog.records
            if r.name == "pipeline.core.progress"]


def test_a_stage_opened_again_inside_itself_is_logged_once(caplog):
    times = StageTimes()
    caplog.set_level(logging.INFO, logger="pipeline.core.progress")
    with stage("meshing link 'arm'", times), stage("meshing link 'arm'"):
        pass
    assert _logged(caplog) == ["meshing link 'arm'"]
    assert list(times.as_dict()) == ["meshing link 'arm'"]


def test_nested_stages_of_other_names_are_each_logged(caplog):
    times = StageTimes()
    caplog.set_level(logging.INFO, logger="pipeline.core.progress")
    with stage("eigen solve of link 'arm'", times), stage("clamping link 'arm'"):
        pass
    # a stage of the same name after the first has ended is logged again
    with stage("meshing link 'arm'"), stage("meshing link 'arm'"):
        pass
    with stage("meshing link 'arm'"):
        pass
    assert _logged(caplog) == ["clamping link 'arm'", "eigen solve of link 'arm'",
                               "meshing link 'arm'", "meshing link 'arm'"]
    assert list(times.as_dict()) == ["eigen solve of link 'arm'"]
