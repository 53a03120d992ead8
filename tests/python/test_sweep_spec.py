"""``sweep`` takes one checked spec object (``SweepSpec``); the keyword form is a thin wrapper over it."""
import numpy as np
import pandas as pd
import pytest

from glintlab.validation.sweep import SweepSpec, sweep


def test_spec_and_keywords_give_the_same_table():
    kw = dict(n=[16, 1000], p=[0.1, 0.5], samples=2000, seed=3, threads=1)
    a = sweep(["gated", "binomial"], **kw)
    b = sweep(SweepSpec(["gated", "binomial"], **kw))
    pd.testing.assert_frame_equal(a, b)


def test_check_names_the_first_bad_field_before_any_file_is_written(tmp_path):
    store = tmp_path / "s.jsonl"
    for field, value in (("threads", True), ("workers", 0), ("chunk", 2.5), ("engine", "mpi"), ("timeout", 0)):
        extra = {"engine": "dask"} if field == "workers" else {}  # workers need the Dask engine
        spec = SweepSpec("gated", n=[16], p=[0.1], store=store, **{field: value, **extra})
        with pytest.raises(ValueError, match=f"^{field} = "):
            spec.check()
        with pytest.raises(ValueError, match=f"^{field} = "):
            sweep(spec)
        assert not store.exists()


def test_numpy_integers_are_counts_everywhere():
    """Before: samples accepted np.int64, threads, workers and chunk refused it."""
    plan = SweepSpec("gated", n=[16], p=[0.1], samples=np.int64(10), threads=np.int64(2), chunk=np.int64(1)).check()
    assert (plan.samples, plan.threads, plan.chunk) == (10, 2, 1)
    assert all(type(x) is int for x in (plan.samples, plan.threads, plan.chunk))
