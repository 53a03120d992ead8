"""C++ plugin laws through gl.load_plugin (ABI: core/include/glintlab/plugin.h).

A loaded plugin stays registered for the life of the process, so every scenario runs in a fresh
interpreter: the laws of this test never appear in gl.laws() of the other test files, whatever order
pytest runs them in. The plugins are those of the build that ctest runs (GLINTLAB_PLUGIN_DIR), else
build/validation/plugins/ of `make build`.
"""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PLUGIN_DIR = Path(os.environ.get("GLINTLAB_PLUGIN_DIR", ROOT / "build" / "validation" / "plugins"))
EXAMPLE = PLUGIN_DIR / "libglintlab_example_plugin.so"
BAD = PLUGIN_DIR / "libglintlab_bad_plugin.so"

pytestmark = pytest.mark.skipif(not EXAMPLE.exists() or not BAD.exists(),
                                reason=f"plugins not built in {PLUGIN_DIR} (make build)")


def isolated(code: str, **env):
    """Runs `code` in a new interpreter (EXAMPLE and BAD defined, glintlab imported as gl)."""
    prelude = f"import numpy as np\nimport glintlab as gl\nEXAMPLE = {str(EXAMPLE)!r}\nBAD = {str(BAD)!r}\n"
    r = subprocess.run([sys.executable, "-c", prelude + textwrap.dedent(code)], capture_output=True, text=True,
                       env={**os.environ, **env}, cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr[-4000:]
    return r.stdout


def test_load_plugin_round_trip():
    isolated("""
        from pathlib import Path
        names = gl.load_plugin(EXAMPLE)
        assert names == ["example_binomial_inversion", "example_round_normal"], names
        assert set(names) <= set(gl.laws())
        assert "(plugin libglintlab_example_plugin.so)" in gl.law_summaries()["example_binomial_inversion"]
        # Loading again (a path-like, another spelling) is a no-op returning the same names.
        assert gl.load_plugin(Path(EXAMPLE)) == names
        assert gl.load_plugin(str(Path(EXAMPLE).parent / "." / Path(EXAMPLE).name)) == names
        assert gl.loaded_plugins() == {str(Path(EXAMPLE).resolve()): names}

        law = gl.law("example_binomial_inversion")
        assert (law.n_uniforms, law.has_pmf, law.binning, law.params, law.precisions) == (1, True, "none", {}, ("float64",))
        # Sampling is evaluate on the batch uniforms, seed for seed, whatever the thread count.
        for n, p in [(30, 0.2), (10.5, 0.7), (1e6, 0.3)]:
            x = law.sample(n, p, size=20_000, seed=5)
            assert np.array_equal(x, law.evaluate(n, p, gl.uniforms(20_000, 1, seed=5)))
        gl.set_num_threads(1)
        one = law.sample(1000, 0.3, size=50_000, seed=9)
        gl.set_num_threads(2)
        assert np.array_equal(one, law.sample(1000, 0.3, size=50_000, seed=9))
        # Arrays of (n, p) broadcast as for any law.
        assert law.sample(np.array([5.0, 50.0]), 0.5, size=(3, 2), seed=1).shape == (3, 2)
        # The pmf is glintlab's exact binomial; the samples pass its chi-square test
        # (3 tests, family-wise false-failure rate 1e-4 at this fixed seed).
        b = gl.law("binomial")
        for n, p in [(10, 0.3), (1000, 0.5), (10.5, 0.7), (1e5, 1e-3)]:
            assert gl.distance(law.pmf(n, p), b.pmf(n, p), "tv") < 1e-12, (n, p)
        for n, p in [(30, 0.2), (10.5, 0.7), (1000, 0.5)]:
            pv = gl.chi2_test(law.sample(n, p, size=200_000, seed=3), law.pmf(n, p)).pvalue
            assert pv > gl.sidak_alpha(1e-4, 3), (n, p, pv)
        # Negative control: samples at p = 0.21 against the law at p = 0.2.
        assert gl.chi2_test(law.sample(30, 0.21, size=200_000, seed=3), law.pmf(30, 0.2)).pvalue < 1e-12
        try:
            law.pmf(2e5, 0.5)
            raise AssertionError("no NotImplementedError above the example's exact domain")
        except NotImplementedError as e:
            assert "(n, p) = (200000, 0.5)" in str(e), e

        rn = gl.law("example_round_normal")
        assert (rn.binning, rn.has_pmf) == ("round", False)
        y = rn.bin(rn.sample(40, 0.3, size=200_000, seed=4))
        assert gl.chi2_test(y, gl.law("gaussian", rounding="round").pmf(40, 0.3)).pvalue > 1e-4
        # Input validation is glintlab's, as for built-in laws.
        for bad in [dict(n=-1, p=0.5), dict(n=5, p=1.5)]:
            try:
                law.sample(bad["n"], bad["p"], size=3, seed=1)
                raise AssertionError("accepted " + repr(bad))
            except ValueError as e:
                assert "is invalid" in str(e)
        # Plugin names are taken for Python custom laws too.
        try:
            gl.custom_law(lambda n, p, u: n, 1, name="example_round_normal")
            raise AssertionError("custom law shadowed a plugin law")
        except ValueError:
            pass
        print("ok")
        """)


def test_load_plugin_errors():
    isolated("""
        import re
        def raises(fn, *parts):
            try:
                fn()
            except ValueError as e:
                for part in parts:
                    assert part in str(e), (part, str(e))
                return
            raise AssertionError("no ValueError")

        raises(lambda: gl.load_plugin("/nonexistent/libnothing.so"), "/nonexistent/libnothing.so", "no such file")
        raises(lambda: gl.load_plugin(42), "path = 42 is invalid")
        raises(lambda: gl.load_plugin("README.md"), "README.md", "cannot load the library")
        # A shared library that is not a plugin: glintlab's own extension module.
        raises(lambda: gl.load_plugin(gl._core.__file__), "does not export glintlab_plugin_laws_v1")
        import os
        os.environ["GLINTLAB_BAD_PLUGIN_CASE"] = "n_uniforms"
        raises(lambda: gl.load_plugin(BAD), BAD, "n_uniforms = 9 is invalid; expected 0 to 4")
        os.environ["GLINTLAB_BAD_PLUGIN_CASE"] = "empty_name"
        raises(lambda: gl.load_plugin(BAD), "laws[0].name = '' is invalid")
        os.environ["GLINTLAB_BAD_PLUGIN_CASE"] = "clash"
        raises(lambda: gl.load_plugin(BAD), "laws[1].name = 'binomial'", "a built-in law has it")
        gl.custom_law(lambda n, p, u: n, 1, name="bad_fine")
        raises(lambda: gl.load_plugin(BAD), "laws[0].name = 'bad_fine'", "a Python custom law has it")
        assert not any(name.startswith("bad_") for name, _ in gl._core.law_infos())
        assert gl.loaded_plugins() == {}
        print("ok")
        """)


def test_misbehaving_plugin_pmfs_are_caught():
    isolated("""
        names = gl.load_plugin(BAD)
        assert "bad_pmf_sum" in names and "bad_pmf_sum" in gl.laws()
        try:
            gl.law("bad_pmf_sum").pmf(3, 0.5)
            raise AssertionError("bad pmf accepted")
        except RuntimeError as e:
            assert "plugin law 'bad_pmf_sum'" in str(e) and "(n, p) = (3, 0.5)" in str(e), e
        try:
            gl.law("bad_pmf_none").pmf(3, 0.5)
            raise AssertionError("no NotImplementedError")
        except NotImplementedError:
            pass
        assert len(gl.law("bad_pmf_wide").pmf(3, 0.5).probs) == 10_000
        # NaN counts from a plugin's evaluate are refused, as a Python custom law's are (plugin.h).
        for call in (lambda: gl.law("bad_nan_eval").sample(3, 0.9, size=4, seed=1),
                     lambda: gl.law("bad_nan_eval").evaluate(3, 0.9, gl.uniforms(4, gl.law("bad_nan_eval").n_uniforms, 1))):
            try:
                call()
                raise AssertionError("NaN counts accepted")
            except ValueError as e:
                assert "law 'bad_nan_eval' returned nan at row 0" in str(e), e
        print("ok")
        """, GLINTLAB_BAD_PLUGIN_CASE="")
