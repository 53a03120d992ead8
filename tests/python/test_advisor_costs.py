"""The scene profile's law costs (glintlab.validation.profile): recorded with the package by default, so
that the advisor's pick and the report do not change with the machine's load; timing in-process is the
explicit costs="measure"."""
import json
import math

import numpy as np
import pytest

import glintlab as gl
from glintlab.cli.main import main
from glintlab.validation import profile as P
from glintlab.validation.bench import DEFAULT_LAWS
from glintlab.api.laws import law_label
from glintlab.resources import data_path

SCHEMES = ("db23_tetrahedral", "zk16_aniso")


def scene_doc():
    """A small grazing plane (n p from 0 to about 40: every regime of the laws)."""
    e = math.radians(25)
    pos = [0.0, -2 * math.cos(e), 2 * math.sin(e)]
    return {"camera": {"resolution": [48, 27], "fov_deg": 60, "position": pos, "look_at": [0, 0, 0], "up": [0, 0, 1]},
            "primitive": {"type": "plane"}, "light": {"type": "point", "position": [0.5, pos[1], pos[2] + 0.5]},
            "material": {"density": 40 * 4194304.0 / 900}}


class LoadedClock:
    """A simulated load: every reading of the clock advances it by a random stretch (seeded), as a
    machine shared with other jobs stretches the time a timed call takes."""

    def __init__(self, seed):
        self.rng, self.now = np.random.default_rng(seed), 0.0

    def __call__(self):
        self.now += float(self.rng.uniform(0, 1e-2))
        return self.now


def loaded(monkeypatch, seed):
    clock = LoadedClock(seed)
    for name in ("perf_counter", "thread_time", "process_time", "monotonic"):
        monkeypatch.setattr(P.time, name, clock)
    monkeypatch.setattr(P, "_COST_CACHE", {})  # a cached measurement would hide a timing
    return clock


def advice(scene):
    prof = P.profile_scene(scene, seed=3, schemes=SCHEMES)
    return gl.advise(prof, max_tv=0.05), gl.advise(prof, max_tv=0.05, per_regime=True), prof


def test_the_default_profile_times_nothing_and_its_pick_ignores_the_load(monkeypatch):
    scene = scene_doc()
    quiet, quiet_regimes, quiet_prof = advice(scene)
    for seed in (1, 2):
        loaded(monkeypatch, seed)
        monkeypatch.setattr(P, "rounds", lambda *a, **k: pytest.fail("the default profile timed the laws"))
        a, r, prof = advice(scene)
        assert (a.law, a.cost) == (quiet.law, quiet.cost)
        assert list(r.per_regime.law) == list(quiet_regimes.per_regime.law)
        assert prof.costs.equals(quiet_prof.costs)
        assert prof.tables["costs"].equals(quiet_prof.tables["costs"])
        monkeypatch.undo()


def test_measured_costs_follow_the_load(monkeypatch):
    # The explicit option is what the default replaced: under two simulated loads its costs differ,
    # so the test above can tell a profile that times the laws from one that does not.
    tables = []
    for seed in (1, 2):
        loaded(monkeypatch, seed)
        tables.append(P.measure_costs(["gated", "head_cf"], size=64, repeats=1))
        monkeypatch.undo()
    assert not np.allclose(tables[0].ns_per_eval, tables[1].ns_per_eval)
    loaded(monkeypatch, 1)
    prof = P.profile_scene(scene_doc(), laws=["gated", "head_cf"], seed=3, schemes=SCHEMES, costs="measure")
    assert (prof.costs.ns_per_eval > 0).all()


def test_every_study_law_has_a_recorded_cost():
    # A law added to the trade study (its traits' study_variants) needs scripts/record_law_costs.py rerun.
    table = P.recorded_costs()
    labels = [law_label(name, params) for name, params in DEFAULT_LAWS]
    assert set(labels) <= set(table.law), f"no recorded cost for {sorted(set(labels) - set(table.law))}"
    assert set(table.law) <= set(labels), "a recorded cost of a law no longer in the trade study"
    assert (table.ns_per_eval > 0).all() and (table.ns_per_trial >= 0).all()
    doc = json.loads(data_path(*P.RECORDED_COSTS).read_text())
    assert doc["machine"] and "record_law_costs.py" in doc["note"]


def test_a_law_without_a_recorded_cost_is_named():
    with pytest.raises(ValueError, match=r"zk16\[cap=4"):
        P.profile_scene(scene_doc(), laws=["gated", ("zk16", {"cap": 4})], schemes=SCHEMES)
    with pytest.raises(ValueError, match="costs"):
        P.profile_scene(scene_doc(), laws=["gated"], schemes=SCHEMES, costs="timed")


def test_advise_cli_measures_only_when_asked(tmp_path, monkeypatch, capsys):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene_doc()))
    monkeypatch.setattr(P, "rounds", lambda *a, **k: pytest.fail("the default advise timed the laws"))
    assert main(["advise", str(path), "--max-tv", "0.05", "--json", "--scheme", "db23_tetrahedral"]) == 0
    default = json.loads(capsys.readouterr().out)
    recorded = dict(zip(P.recorded_costs().law, P.recorded_costs().ns_per_eval))
    assert {c["law"] for c in default["candidates"]} == set(recorded)
    calls = []
    monkeypatch.setattr(P, "rounds", lambda todo, points, best, repeats, size: calls.append(len(todo)) or
                        best.update({(label, n, p): 10.0 for label, lw in todo.items() for n, p in points(lw)}))
    monkeypatch.setattr(P, "_COST_CACHE", {})
    assert main(["advise", str(path), "--max-tv", "0.05", "--costs", "measure", "--quiet"]) == 0
    assert calls == [len(recorded)]
