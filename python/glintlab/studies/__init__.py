"""The studies: one module per report section (paper figure or question), plus the helpers several share
(:mod:`~glintlab.studies.lod`, :mod:`~glintlab.studies.convergence`, :mod:`~glintlab.studies.base`).

Each study describes itself (``NAME``, ``TITLE``, ``MEANING``, ``DEFAULTS``, ``QUICK``, ``NOTEBOOK``,
``TABLE``), computes tables from parameters (``compute``) and draws figures from tables (``figures``);
the report (:mod:`glintlab.report.sections`) discovers them."""
