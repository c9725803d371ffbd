"""Studies: many runs of one workflow -- mode truncation ("how many modes are enough?")
and design variants -- on local worker processes or an existing Dask cluster.

``pipeline study STUDY.yaml``: :func:`pipeline.study.spec.load_study` reads the study,
:func:`pipeline.study.cases.study_cases` lists its cases (each an override set with an
input hash), :func:`pipeline.study.engine.run_study` runs the missing ones through
``dask.distributed`` and writes one tidy table (Parquet and CSV), the per-link mode
recommendation and a manifest.
"""

from pipeline.study.spec import StudySpec, load_study

__all__ = ["StudySpec", "load_study"]
