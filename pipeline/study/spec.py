"""The study YAML: a base workflow and what to vary (schema, validated by pydantic).

.. code-block:: yaml

    name: crane_modes
    workflow: ../workflows/mobile_crane.yaml     # relative to this file
    quick: false                                 # the workflow's quick: overrides
    set: {links.boom.damping.ratio: 0.02}        # overrides of every case (as --set)
    analyses: [release]                          # run these (default: every analysis)
    truncation:                                  # "how many modes are enough?"
      links: [boom]                              # default: every flexible link
      modes: [0, 1, 2, 3]                        # kept-mode counts to try
      series: [q:HEAVE.d, q:PITCH.theta]         # compared with the richest case
      tolerance: 0.01                            # relative RMS difference accepted
    design:                                      # variants (any --set paths)
      grid: {forces.load.force: [[0, -1e3, 0], [0, -2e3, 0]]}
      cases: [{drivers.LUFF.theta.value: -0.8}]
      random: {n: 8, seed: 1, ranges: {gravity.1: [-9.9, -9.7]}}
    outputs:                                     # one value per case and series
      - {name: peak_heave, series: q:HEAVE.d, reduce: peak}
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from pipeline.core.errors import ConfigError
from pipeline.workflow.link_spec import Strict
from pipeline.workflow.yaml_io import config_error, load_yaml


class TruncationSpec(Strict):
    links: list[str] | None = Field(None, description="flexible links (default: all)")
    modes: list[int | dict[str, Any]] = Field(
        min_length=2, description="kept modes to compare, leanest first, richest last: "
                                  "counts, or rules such as {effective_mass: 0.9} or "
                                  "{f_max: 50}")
    series: list[str] = Field(min_length=1, description="series compared between counts")
    tolerance: float = Field(0.01, gt=0, description="accepted relative RMS difference "
                                                    "from the richest count")

    @field_validator("modes")
    @classmethod
    def _counts(cls, value: list) -> list:
        from pipeline.workflow.schema import ModeSelection

        for v in value:
            if isinstance(v, dict):
                ModeSelection.model_validate(v)  # a rule a flexible link accepts
            elif v < 0:
                raise ValueError(f"expected counts >= 0, got {v}")
        labels = [mode_label(v) for v in value]
        if len(set(labels)) != len(labels):
            raise ValueError("expected distinct entries")
        if all(isinstance(v, int) for v in value):
            return sorted(value)
        return value


def mode_label(v) -> str:
    """"2" for a count, "effective_mass=0.9" for a rule."""
    if isinstance(v, dict):
        return ", ".join(f"{k}={v[k]}" for k in sorted(v))
    return str(v)


def mode_text(label: str) -> str:
    """A mode label as read in a sentence: "2 modes", or the rule as it is."""
    return f"{label} modes" if label.isdigit() else label


class RandomSpec(Strict):
    n: int = Field(ge=1, le=100_000)
    seed: int = 0
    ranges: dict[str, tuple[float, float]] = Field(min_length=1,
                                                    description="path: [low, high]")


class DesignSpec(Strict):
    grid: dict[str, list[Any]] = Field(default_factory=dict,
                                       description="path: values (every combination)")
    cases: list[dict[str, Any]] = Field(default_factory=list, description="override sets")
    random: RandomSpec | None = None


class OutputSpec(Strict):
    name: str = Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")
    series: str
    reduce: Literal["max", "min", "peak", "final", "rms", "mean"] = "peak"
    analysis: str | None = Field(None, description="default: the first analysis run")


class StudySpec(Strict):
    name: str = Field(pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")
    workflow: str
    quick: bool = False
    set: dict[str, Any] = Field(default_factory=dict,
                                description="overrides of the base for every case")
    analyses: list[str] | None = None
    truncation: TruncationSpec | None = None
    design: DesignSpec | None = None
    outputs: list[OutputSpec] = Field(default_factory=list)

    @model_validator(mode="after")
    def _something(self):
        if self.truncation is None and self.design is None:
            raise ValueError("give truncation: or design: (what the study varies)")
        return self


def load_study(path: str | Path) -> tuple[StudySpec, Path]:
    """(StudySpec, the base workflow's path) of a study YAML.

    Raises
    ------
    ConfigError
        File, YAML or schema errors, naming file:line: yaml.path.
    """
    path = Path(path)
    data, lines = load_yaml(path)
    try:
        spec = StudySpec.model_validate(data)
    except ValidationError as exc:
        raise config_error(exc, path, data, lines) from None
    base = (path.parent / spec.workflow).resolve()
    if not base.is_file():
        raise ConfigError(f"{path}:{lines.get(('workflow',), 1)}: workflow: file "
                          f"{str(base)!r} not found")
    return spec, base
