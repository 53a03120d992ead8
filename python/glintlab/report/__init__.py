"""The figure report (``make run``): runs the configured studies and writes the only HTML page."""
