"""The ``glintlab`` command line (entry point: :func:`glintlab.cli.main.main`)."""
