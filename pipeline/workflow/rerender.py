"""Draw a finished run's pictures again from what it saved, with other settings and without
running any analysis (``pipeline render RUN_FOLDER``).

The run's manifest names its workflow, overrides and ``--quick``; the machine is built
again from them (the reduced links come from the shared cache), every analysis case's
histories are read back from its ``.npz`` (the inverse of
:func:`pipeline.workflow.outputs.export_npz`), and the plots, renders and animations are
drawn into the run's folder (each file replaced atomically), its report made again.
Overrides may change only how results are drawn (``outputs.*``): the results are the
run's.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.workflow.analyses import AnalysisResult
from pipeline.workflow.names import slug

logger = logging.getLogger(__name__)

__all__ = ["read_result", "render_run"]

#: the arrays of an .npz that are not extras (export_npz's own keys)
_MAIN = ("t", "q", "qd", "qdd", "coordinates", "success", "message", "verdict", "warnings")


def read_result(path: Path, name: str, kind: str, case: str, state_units: dict) -> AnalysisResult:
    """The AnalysisResult an analysis case's ``.npz`` at ``path`` holds (``state_units``:
    {"<element>.<state>": unit} of the machine's element states)."""
    with np.load(path, allow_pickle=False) as d:
        arrays = {k: d[k] for k in d.files}
    def group(prefix):
        return {k[len(prefix):]: v for k, v in arrays.items() if k.startswith(prefix)}

    extra = {k: v for k, v in arrays.items()
             if k not in _MAIN and ":" not in k}
    return AnalysisResult(
        name=name, type=kind, case=case, success=bool(arrays["success"]),
        message=str(arrays["message"]), coordinates=tuple(str(c) for c in arrays["coordinates"]),
        t=arrays["t"], q=arrays["q"], qd=arrays["qd"], qdd=arrays["qdd"],
        forces=group("force:"), energies=group("energy:"), extra=extra,
        states={k: (state_units.get(k, ""), v) for k, v in group("state:").items()},
        verdict=str(arrays["verdict"]), warnings=tuple(str(w) for w in arrays["warnings"]))


def render_run(folder: str | Path, sets=(), cache_dir=None) -> list[str]:
    """Draw the plots, renders and animations of the run in ``folder`` again (``sets``:
    ``"outputs....=value"`` overrides); returns the files written.

    Raises
    ------
    ConfigError
        No manifest, an override outside ``outputs``, or a run without its ``.npz``
        results (``outputs.exports.npz: false``).
    """
    from pipeline.invariants.cache import default_links_dir
    from pipeline.post.report import write_report
    from pipeline.workflow import build_machine, load_workflow
    from pipeline.workflow.outputs import write_outputs
    from pipeline.workflow.run import build_cases

    folder = Path(folder)
    manifest = folder / "manifest.json"
    if not manifest.is_file():
        raise ConfigError(f"{folder}: expected a run's folder holding manifest.json")
    man = json.loads(manifest.read_text())
    for s in sets:
        if not str(s).startswith("outputs."):
            raise ConfigError(f"render: --set {s}: expected outputs.<...>=value (how results "
                              f"are drawn); the results are the run's")
    # the run's own overrides (its quick: ones first, applied again alike), then these
    again = [f"{path}={json.dumps(value)}" for path, value in man.get("overrides", [])]
    wf = load_workflow(man["workflow"], again + list(sets), bool(man.get("quick")))
    cache_dir = Path(cache_dir) if cache_dir is not None else default_links_dir()
    base = build_machine(wf, cache_dir)
    machines = build_cases(wf, base, cache_dir)
    results: dict[str, list[AnalysisResult]] = {}
    for a in wf.spec.analyses:
        for case in a.cases or [None]:
            label = case.label if case else ""
            path = folder / f"{a.name}{'_' + slug(label) if label else ''}.npz"
            if not path.is_file():
                raise ConfigError(f"{folder}: render: {path.name} is missing: the run saved "
                                  f"no results to draw from (outputs.exports.npz: true)")
            system = machines[label].system
            units = dict(zip(system.state_names, system.state_units, strict=True))
            results.setdefault(a.name, []).append(read_result(path, a.name, a.type, label,
                                                              units))
    timings: dict[str, float] = {}
    files = write_outputs(folder, _drawings_only(wf), machines, results, timings)
    write_report(folder)
    logger.info("%s: drawn again in %.1f s", folder, sum(timings.values()))
    return files


def _drawings_only(wf):
    """``wf`` with its exports and ParaView series off: render draws, it does not export."""
    from dataclasses import replace

    exports = wf.spec.outputs.exports.model_copy(update={"csv": False, "npz": False,
                                                         "vtu": False})
    outputs = wf.spec.outputs.model_copy(update={"exports": exports})
    return replace(wf, spec=wf.spec.model_copy(update={"outputs": outputs}))
