"""The figure report (``make run``): runs the configured studies and writes the page.

:mod:`~glintlab.report.sections` finds the studies (the registry of sections),
:mod:`~glintlab.report.config` loads and checks configurations, :mod:`~glintlab.report.runner` runs them
(records, progress, report.json), :mod:`~glintlab.report.html` writes the HTML pages (the report's and the
extremes suite's) and :mod:`~glintlab.report.thumbnail` the README's contact sheet. This package imports
none of them, so that a study can use :mod:`~glintlab.report.html` without loading the registry.
"""
