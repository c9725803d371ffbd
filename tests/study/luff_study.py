"""A design study of the mobile crane's release over luff angles (quick mode), written
for the study tests and the study benchmark."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def write_luff_study(path: Path, design: str) -> Path:
    """Write the study to ``path`` with ``design`` (the YAML of its design: mapping, e.g.
    ``"grid: {drivers.LUFF.theta.value: [-0.8, -1.0]}"``); return the path."""
    path.write_text(f"""\
name: luff
workflow: {ROOT / 'workflows' / 'mobile_crane.yaml'}
quick: true
analyses: [release]
design:
  {design}
outputs:
  - {{name: peak_heave, series: q:HEAVE.d, reduce: peak}}
""")
    return path
