"""The studies: one module per report section (paper figure or question), plus the helpers several share
(:mod:`~glintlab.studies.lod`, :mod:`~glintlab.studies.convergence`, :mod:`~glintlab.studies.base`,
:mod:`~glintlab.studies.experiment_plots`), named in :data:`HELPERS`.

Each study describes itself (``NAME``, ``TITLE``, ``MEANING``, ``DEFAULTS``, ``QUICK``, ``NOTEBOOK``,
``TABLE``), computes tables from parameters (``compute``) and draws figures from tables (``figures``);
the report (:mod:`glintlab.report.sections`) discovers them: every module here that is not a helper
(nor starts with ``_``) is a section, and one that lacks a section's parts is an error, not skipped."""

# The modules of this package that are not report sections (shared code). A new helper joins this
# list (or starts with "_"); any other module must be a complete study.
HELPERS = ("base", "convergence", "lod", "experiment_plots", "sampling_lighting", "scene_frames", "pipeline_metrics")
