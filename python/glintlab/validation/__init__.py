"""The validation layer: references, the one engine that fills (law x grid x metric) tables (exact and
sampled), resumable stores, experiment and bounds documents, the extremes suite, benchmarks, scene
profiles and the advisor, and the engines that run rows (threads, Dask)."""
