# The README's two commands:  `make demo`  and  `make test`.
# Each sets up only what it uses:
#   demo: a virtualenv in .venv with the package (its run-time dependencies),
#         Mesa's EGL (headless OpenGL) through apt where missing, and three.js
#         for the report's 3D viewer (npm, where node is installed);
#   test: the same plus the dev extra (pytest and the test tools), a virtual
#         X server (xvfb, xauth) for the viewer tests, headless Chromium (apt)
#         and, through npm into ./node_modules, the Khronos glTF validator and
#         three.js (the report's 3D viewer and the cross-renderer tests).

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
RUN_STAMP := $(VENV)/.installed-run
DEV_STAMP := $(VENV)/.installed
NODE_STAMP := node_modules/.installed

.PHONY: test demo venv lint sysdeps-demo sysdeps-test clean

# two pytest worker processes (pytest-xdist), each test file on one of them (its
# module fixtures made once): the suite is mostly single-threaded work (fresh
# processes importing JAX, compiling), so two cores run it in about two thirds the time
test: $(DEV_STAMP) $(NODE_STAMP) sysdeps-test lint
	$(PY) -m pytest -q -n 2 --dist loadfile

lint: $(DEV_STAMP)
	$(PY) -m ruff check brdf fitting data_loaders shaders brdf_fit tests benchmarks tools examples

demo: $(RUN_STAMP) $(NODE_STAMP) sysdeps-demo
	$(VENV)/bin/brdf-fit demo --out demo-output
	@echo
	@echo "brdf-fit is installed in $(VENV): run '. $(VENV)/bin/activate' (or call $(VENV)/bin/brdf-fit)"
	@echo "to use the README's brdf-fit commands; demo-output/report/index.html is the report,"
	@echo "demo-output/library/index.html the library of the three materials."

venv: $(DEV_STAMP)

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

$(RUN_STAMP): pyproject.toml | $(PY)
	@echo "installing brdf-fit and its dependencies into $(VENV) (pip; about a minute the first time)"
	PYTHONWARNINGS=ignore $(PY) -m pip install -q -e .
	touch $(RUN_STAMP)

$(DEV_STAMP): pyproject.toml | $(PY)
	@echo "installing brdf-fit with its dev extra into $(VENV) (pip; about a minute the first time)"
	PYTHONWARNINGS=ignore $(PY) -m pip install -q -e '.[dev]'
	touch $(DEV_STAMP) $(RUN_STAMP)

# The Khronos glTF validator (npm gltf-validator) for the export tests and
# three.js for the report's 3D viewer, into ./node_modules; without node/npm
# those tests skip (and reports omit the viewer) and say why.
$(NODE_STAMP): package.json package-lock.json
	@if command -v npm >/dev/null 2>&1; then \
		npm ci --no-audit --no-fund && touch $(NODE_STAMP) \
			|| echo "npm ci failed: no three.js (the report shows no 3D viewer) and no glTF validator (those tests skip)"; \
	else \
		echo "npm not found: no three.js (the report shows no 3D viewer) and no glTF validator (those tests skip)"; \
	fi

sysdeps-demo:
	@bash .ci/install-system-packages demo

sysdeps-test:
	@bash .ci/install-system-packages test

clean:
	rm -rf $(VENV) demo-output .pytest_cache node_modules
