# glintlab: see README.md. Every target installs what is missing first (scripts/install-deps.sh).
SHELL := /bin/bash
PYTHON := /usr/bin/python3
VENV := .venv
JOBS ?= 2
BUILD_TYPE ?= Release
QUICK ?=

.PHONY: build run test bench sanitize deps venv clean

deps:
	@bash scripts/install-deps.sh

build: deps
	@cmake -S . -B build -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) -DGLINTLAB_PYTHON_EXE=$(PYTHON) > build.log 2>&1 \
	  || { cat build.log; exit 1; }
	@cmake --build build -j $(JOBS) >> build.log 2>&1 || { tail -60 build.log; echo "make build: failed (build.log)"; exit 1; }
	@grep -E 'warning' build.log || true
	@$(MAKE) --no-print-directory venv

# A venv over Debian's interpreter (numpy, scipy, matplotlib come from --system-site-packages) that
# sees the in-tree package bindings/python/glintlab and has the `glintlab` command.
venv:
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv --system-site-packages $(VENV)
	@site=$$($(VENV)/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])'); \
	  echo "$(CURDIR)/bindings/python" > $$site/glintlab.pth
	@printf '#!%s\nimport sys\nfrom glintlab.cli import main\nsys.exit(main())\n' "$(CURDIR)/$(VENV)/bin/python" > $(VENV)/bin/glintlab
	@chmod +x $(VENV)/bin/glintlab
	@# A "python3" Jupyter kernel inside the venv, so notebooks run with the installed package.
	@test -f $(VENV)/share/jupyter/kernels/python3/kernel.json || \
	  $(VENV)/bin/python -m ipykernel install --sys-prefix --name python3 --display-name "Python 3 (glintlab)" > /dev/null

run: build
	@$(VENV)/bin/glintlab report --out out/report $(if $(QUICK),--quick,)

test: build
	@cd build && ctest --output-on-failure -j $(JOBS)

bench: build
	@$(VENV)/bin/python validation/bench/bench_binomial.py --cpp build/validation/glintlab_bench_binomial
	@$(VENV)/bin/python validation/bench/bench_laws.py
	@$(VENV)/bin/python validation/bench/bench_ground_truth.py

# C++ tests under AddressSanitizer + UndefinedBehaviorSanitizer (no Python module in this build).
sanitize: deps
	@cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DGLINTLAB_SANITIZE=ON -DGLINTLAB_PYTHON=OFF > build-asan.log 2>&1 \
	  || { cat build-asan.log; exit 1; }
	@cmake --build build-asan -j $(JOBS) --target glintlab_tests >> build-asan.log 2>&1 \
	  || { tail -60 build-asan.log; echo "make sanitize: build failed (build-asan.log)"; exit 1; }
	@cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --output-on-failure -j $(JOBS)

clean:
	rm -rf build build-asan out build.log build-asan.log
