# glintlab: see README.md. Every target installs what is missing first (scripts/install-deps.sh).
SHELL := /bin/bash
PYTHON := /usr/bin/python3
VENV := .venv
JOBS ?= 2
BUILD_TYPE ?= Release
QUICK ?=

.PHONY: build build-all run test bench docs sanitize fuzz clang-test deps venv clean wheel format

deps:
	@bash scripts/install-deps.sh

# What `make run` needs and nothing more: the Python module glintlab._core with what it links (the
# core, the validation libraries) and the example plugin (docs/guide/python.md). The C++ tests and the
# benchmarks' programs are built by `make test` and `make bench` (build-all): a fresh clone's first
# report waits for 340 s of compiler CPU time instead of 556 s (measured without ccache).
BUILD_TARGETS := _core glintlab_example_plugin

build: deps
	@cmake -S . -B build -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DGLINTLAB_PYTHON_EXE=$(PYTHON) > build.log 2>&1 \
	  || { cat build.log; exit 1; }
	@cmake --build build -j $(JOBS) --target $(BUILD_TARGETS) >> build.log 2>&1 \
	  || { tail -60 build.log; echo "make build: failed (build.log)"; exit 1; }
	@grep -E 'warning' build.log || true
	@$(MAKE) --no-print-directory venv

# Everything CMake builds: the report's part (build), then the C++ tests, the broken test plugin and
# the benchmarks' programs.
build-all: build
	@cmake --build build -j $(JOBS) > build-all.log 2>&1 \
	  || { tail -60 build-all.log; echo "make: building the tests and benchmarks failed (build-all.log)"; exit 1; }
	@grep -E 'warning' build-all.log || true

# A venv over Debian's interpreter (numpy, scipy, matplotlib come from --system-site-packages) that
# sees the in-tree package python/glintlab and has the `glintlab` command.
venv:
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv --system-site-packages $(VENV)
	@site=$$($(VENV)/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])'); \
	  echo "$(CURDIR)/python" > $$site/glintlab.pth
	@# The __main__ guard: Dask's LocalCluster starts workers by spawn, which re-imports this script.
	@printf '#!%s\nimport sys\nfrom glintlab.cli.main import main\nif __name__ == "__main__":\n    sys.exit(main())\n' "$(CURDIR)/$(VENV)/bin/python" > $(VENV)/bin/glintlab
	@chmod +x $(VENV)/bin/glintlab
	@# A "python3" Jupyter kernel inside the venv, so notebooks run with the installed package.
	@test -f $(VENV)/share/jupyter/kernels/python3/kernel.json || \
	  $(VENV)/bin/python -m ipykernel install --sys-prefix --name python3 --display-name "Python 3 (glintlab)" > /dev/null

# `pip install .` (pyproject.toml, backend/glintlab_build.py) as a wheel in dist/, built by CMake in build-wheel/.
wheel: deps venv
	@$(VENV)/bin/python -m pip wheel --no-index --no-deps -q -w dist . > build-wheel.log 2>&1 \
	  || { tail -60 build-wheel.log; echo "make wheel: failed (build-wheel.log)"; exit 1; }

run: build
	@$(VENV)/bin/glintlab report --out out/report $(if $(QUICK),--quick,)

# wheel first: tests/python/test_install.py's `pip install .` then only relinks (outside ctest's timeout).
test: build-all wheel
	@cd build && ctest --output-on-failure -j $(JOBS)

# The C++ style (.clang-format); make test checks it ("lint: clang-format").
format:
	@bash scripts/format-cpp.sh

bench: build-all
	@# Issue 21: the renderer and sweep paths, each beside its baseline (out/bench/paths.*).
	@$(VENV)/bin/python bench/bench_paths.py --busy
	@$(VENV)/bin/python bench/bench_binomial.py --cpp build/bench/glintlab_bench_binomial
	@$(VENV)/bin/python bench/bench_laws.py
	@$(VENV)/bin/python bench/bench_ground_truth.py
	@$(VENV)/bin/python bench/bench_glinty_ndf.py --out out/bench
	@$(VENV)/bin/python bench/bench_wwh18.py --out out/bench
	@$(VENV)/bin/python bench/bench_sampler_test.py --out out/bench
	@$(VENV)/bin/python bench/bench_sampler_pixel.py --out out/bench
	@$(VENV)/bin/python bench/bench_shader.py
	@$(VENV)/bin/python bench/bench_method_shader.py
	@$(VENV)/bin/python bench/bench_counting_shaders.py
	@# Issue 39: glintlab cost for three architectures (budget 5 s), and the advisor's law costs per pixel.
	@$(VENV)/bin/python bench/bench_gpu_cost.py
	@$(VENV)/bin/python bench/bench_advisor_costs.py
	@$(VENV)/bin/python bench/bench_scene_trace.py --no-numpy
	@# Issue 40: the exact p of an extended light per call (the hidden Catch2 case) and per 960 x 540 frame.
	@$(VENV)/bin/python bench/bench_lighting.py
	@$(VENV)/bin/glintlab bench --out out/bench
	@$(VENV)/bin/python bench/bench_dask.py
	@$(VENV)/bin/glintlab aniso --out out/bench/aniso
	@# Issue 8's target: a 1920 x 1080 profile with every law and grid scheme in under 20 s (times per scene).
	@$(VENV)/bin/glintlab profile python/glintlab/data/scenes/*.json --out out/bench/scenes
	@# Issue 32: the report's seconds per section (wall and CPU), full and --quick, against their budgets.
	@$(VENV)/bin/python bench/bench_report.py --run
	@# Issue 41: glintlab check on a pipeline of every stage (< 60 s) and on the shipped pipelines (< 3 min).
	@$(VENV)/bin/python bench/bench_pipeline.py --out out/bench

# The documentation: the API reference from the docstrings (docs/api), the Markdown pages (docs/*.md,
# docs/math) and the notebooks, built by Sphinx into out/docs/ (open out/docs/index.html). Any Sphinx
# warning fails the target (-W); --keep-going lists them all first. The venv's interpreter imports the
# compiled glintlab._core, hence the dependency on build.
docs: build
	@$(VENV)/bin/python -m sphinx -W --keep-going -q -b html docs out/docs
	@echo "make docs: out/docs/index.html"

# C++ tests under AddressSanitizer + UndefinedBehaviorSanitizer (no Python module in this build).
sanitize: deps
	@cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DGLINTLAB_SANITIZE=ON -DGLINTLAB_PYTHON=OFF > build-asan.log 2>&1 \
	  || { cat build-asan.log; exit 1; }
	@cmake --build build-asan -j $(JOBS) --target glintlab_tests >> build-asan.log 2>&1 \
	  || { tail -60 build-asan.log; echo "make sanitize: build failed (build-asan.log)"; exit 1; }
	@cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/sanitize/lsan.supp \
	  ctest --output-on-failure -j $(JOBS)

# The core and its C++ tests built with Clang (Debian 12's clang-14 and libomp-14-dev) as well as GCC: a
# library users link must build with both. Release flags as users build (at -O1 or -O2 clang-14 does
# not vectorize the `omp simd` kernels and warns); every C++ test runs. The compiler-specific code
# (the SIMD dispatch files, the half-float conversion of core/include/glintlab/base/float16.hpp) is
# compiled and tested here.
clang-test: deps
	@CC=clang CXX=clang++ cmake -S . -B build-clang -DCMAKE_BUILD_TYPE=Release \
	  -DGLINTLAB_PYTHON=OFF > build-clang.log 2>&1 || { cat build-clang.log; exit 1; }
	@cmake --build build-clang -j $(JOBS) --target glintlab_tests >> build-clang.log 2>&1 \
	  || { tail -60 build-clang.log; echo "make clang-test: build failed (build-clang.log)"; exit 1; }
	@grep -E 'warning' build-clang.log || true
	@cd build-clang && ./tests/glintlab_tests

# libFuzzer (clang, ASan + UBSan) on the experiment and bounds parsers for FUZZ_SECONDS, from a fresh
# corpus of the shipped and test documents. A crash, leak, timeout or sanitizer report fails the target;
# the input is kept as build-fuzz/crash-* (replay: build-fuzz/validation/glintlab_fuzz_documents FILE).
FUZZ_SECONDS ?= 30
fuzz: deps
	@CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DGLINTLAB_FUZZ=ON \
	  -DGLINTLAB_PYTHON=OFF > build-fuzz.log 2>&1 || { cat build-fuzz.log; exit 1; }
	@cmake --build build-fuzz -j $(JOBS) --target glintlab_fuzz_documents >> build-fuzz.log 2>&1 \
	  || { tail -60 build-fuzz.log; echo "make fuzz: build failed (build-fuzz.log)"; exit 1; }
	@rm -rf build-fuzz/corpus && mkdir -p build-fuzz/corpus
	@shopt -s nullglob globstar; \
	  for f in examples/*.json python/glintlab/data/report/*.json python/glintlab/data/bounds/*.json tests/data/documents/**/*.json; do \
	    cp "$$f" "build-fuzz/corpus/$$(echo "$$f" | tr / _)"; done
	@cd build-fuzz && ./validation/glintlab_fuzz_documents corpus -dict=../validation/fuzz/json.dict \
	  -max_total_time=$(FUZZ_SECONDS) -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 > fuzz.log 2>&1 \
	  || { tail -60 fuzz.log; echo "make fuzz: the fuzzer found a failure (build-fuzz/fuzz.log, build-fuzz/crash-*)"; exit 1; }
	@grep -E '^(Done|stat::number_of_executed_units|stat::peak_rss_mb)' build-fuzz/fuzz.log; \
	  echo "make fuzz: no failure in $(FUZZ_SECONDS) s ($$(ls build-fuzz/corpus | wc -l) corpus inputs)"

clean:
	rm -rf build build-asan build-fuzz build-clang build-wheel dist out build.log build-all.log build-asan.log build-fuzz.log \
	  build-clang.log build-wheel.log
