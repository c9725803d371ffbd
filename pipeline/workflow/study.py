"""Case studies ("how many modes are enough?"): distance of every case from a reference case."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.workflow.series import series


@dataclass(frozen=True)
class Convergence:
    """Per series, per case: RMS and max |difference| from the reference case over the
    common output times, and the RMS relative to the reference's RMS (same unit as the
    series; relative: dimensionless)."""

    labels: tuple[str, ...]
    reference: str
    rms: dict
    peak: dict
    relative: dict
    units: dict


def convergence(results, machines, names, reference: str | None = None) -> Convergence:
    """Compare each case of one analysis with ``reference`` (default the last case)."""
    ref = results[-1] if reference is None else next(r for r in results if r.case == reference)
    rms, peak, rel, units = {}, {}, {}, {}
    for s in names:
        y_ref = series(ref, machines[ref.case].mechanism, s, machines[ref.case].parts)
        units[s] = y_ref.unit
        scale = float(np.sqrt(np.mean(y_ref.values ** 2)))
        rms[s], peak[s], rel[s] = [], [], []
        for r in results:
            y = series(r, machines[r.case].mechanism, s, machines[r.case].parts).values
            k = min(len(y), len(y_ref.values))
            d = y[:k] - y_ref.values[:k]
            rms[s].append(float(np.sqrt(np.mean(d ** 2))) if k else np.nan)
            peak[s].append(float(np.abs(d).max(initial=0.0)) if k else np.nan)
            rel[s].append(rms[s][-1] / scale if scale > 0 else np.nan)
    return Convergence(tuple(r.case for r in results), ref.case, rms, peak, rel, units)


def write_convergence_csv(path: Path, c: Convergence) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["series", "unit", "case", "rms_difference", "max_difference",
                    "relative_rms_difference", "reference"])
        for s in c.rms:
            for i, label in enumerate(c.labels):
                w.writerow([s, c.units[s], label, f"{c.rms[s][i]:.6g}", f"{c.peak[s][i]:.6g}",
                            f"{c.relative[s][i]:.6g}", c.reference])
