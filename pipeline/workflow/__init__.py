"""User-facing specs (YAML, pydantic) and the workflow runner (docs/workflows.md).

Python API::

    from pipeline.workflow import load_workflow, build_machine, run_workflow
    wf = load_workflow("workflows/double_pendulum.yaml", sets=["analyses.swing.t_end=0.5"],
                       quick=True)                 # validated; errors name file:line: path
    m = build_machine(wf)                          # Machine: system, q0, qd0, parts (reduced)
    res = run_workflow(wf, out_root=tmp_path)      # RunResult
    r = res.result("swing", case="rigid")          # AnalysisResult: t, q, qd, qdd, forces,
                                                   # energies, extra (M, K, frequencies_hz ...)
    from pipeline.workflow.series import series
    y = series(r, res.machines[r.case].mechanism, "marker:lower.B:y").values
"""

from pipeline.workflow.analyses import AnalysisResult, run_analysis
from pipeline.workflow.build import Machine, build_machine
from pipeline.workflow.load import Workflow, load_workflow
from pipeline.workflow.run import RunResult, run_workflow

__all__ = ["AnalysisResult", "Machine", "RunResult", "Workflow", "build_machine",
           "load_workflow", "run_analysis", "run_workflow"]
