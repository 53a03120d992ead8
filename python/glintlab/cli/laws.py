"""``glintlab laws``: the registered counting laws, one line each."""
from __future__ import annotations

from ..api.laws import law_summaries


def add_parser(sub):
    p = sub.add_parser("laws", help="list the registered counting laws")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    for name, summary in law_summaries().items():
        print(f"{name:12s} {summary}")
    return 0
