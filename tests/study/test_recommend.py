"""The truncation recommendation reads each case's saved series against the richest case's;
without the richest case there is no reference, and no recommendation (issue 24: a study
whose 4-mode case failed printed "4 modes recommended (within 2 % of 4 modes)", compared
against the 3-mode case)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from pipeline.study.cases import Case
from pipeline.study.engine import _case_file, recommend


def _cases(tmp_path, saved: dict[str, float]) -> list[Case]:
    """Truncation cases 1..4 modes of link 'outer'; ``saved``: modes -> the amplitude of
    the sine its case saved (absent: the case did not finish)."""
    cases = [Case(f"outer={n} modes", {}, "truncation", "outer", str(n), n - 1,
                  input_hash=f"{n:016d}") for n in (1, 2, 3, 4)]
    t = np.linspace(0.0, 1.0, 50)
    (tmp_path / "cases").mkdir()
    for c in cases:
        if c.modes in saved:
            np.savez(_case_file(tmp_path, c), **{"t|run:tip": t,
                                                 "v|run:tip": saved[c.modes] * np.sin(t)})
    return cases


SPEC = SimpleNamespace(truncation=SimpleNamespace(tolerance=0.02))


def test_the_leanest_case_within_the_tolerance_of_the_richest_is_recommended(tmp_path):
    rec = recommend(SPEC, _cases(tmp_path, {"1": 0.8, "2": 0.99, "3": 1.0, "4": 1.0}),
                    tmp_path)["outer"]
    assert rec["reference"] == "4" and rec["recommended"] == "2"


def test_no_recommendation_when_the_richest_case_did_not_finish(tmp_path):
    rec = recommend(SPEC, _cases(tmp_path, {"1": 0.8, "2": 0.99, "3": 1.0}),
                    tmp_path)["outer"]
    assert rec["recommended"] is None and rec["reference"] == "4"
    assert "the reference case (4) did not finish" in rec["why"]
