# The README's two commands:  `make demo`  and  `make test`.
# Each sets up only what it uses:
#   demo: a virtualenv in .venv with the package (its run-time dependencies),
#         Mesa's EGL (headless OpenGL) through apt where missing, and three.js
#         for the report's 3D viewer (npm, where node is installed);
#   test: the same plus the dev extra (pytest and the test tools), a virtual
#         X server (xvfb, xauth) for the viewer tests, headless Chromium (apt)
#         and, through npm into ./node_modules, the Khronos glTF validator and
#         three.js (the report's 3D viewer and the cross-renderer tests).
# Optional: `make blender` (Blender 5 as a Python module, for the Cycles judge).

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
RUN_STAMP := $(VENV)/.installed-run
DEV_STAMP := $(VENV)/.installed
NODE_STAMP := node_modules/.installed

.PHONY: test demo venv blender lint sysdeps-demo sysdeps-test clean

# two pytest worker processes (pytest-xdist), each test file on one of them (its
# module fixtures made once): the suite is mostly single-threaded work (fresh
# processes importing JAX, compiling), so two cores run it in about two thirds the time;
# the 25 slowest tests are listed at the end (the suite stays within 15 minutes)
test: $(DEV_STAMP) $(NODE_STAMP) sysdeps-test lint
	$(PY) -m pytest -q -n 2 --dist loadfile --durations=25

lint: $(DEV_STAMP)
	$(PY) -m ruff check brdf fitting data_loaders shaders brdf_fit tests benchmarks tools examples notebooks

demo: $(RUN_STAMP) $(NODE_STAMP) sysdeps-demo
	$(VENV)/bin/brdf-fit demo --out demo-output
	@echo
	@echo "brdf-fit is installed in $(VENV): run '. $(VENV)/bin/activate' (or call $(VENV)/bin/brdf-fit)"
	@echo "to use the README's brdf-fit commands; demo-output/report/index.html is the report,"
	@echo "demo-output/library/index.html the library of the three materials."

venv: $(DEV_STAMP)

# Optional, for benchmarks/engine_blender.py and tests/test_engine_blender.py (which skips
# without it): Blender 5 as a Python module (pip's bpy, a 374 MB wheel, Python 3.11 only) in a
# virtualenv of its own, .venv-blender: bpy 5.0.1 requires numpy < 2, and installed beside the
# toolkit it downgrades numpy, JAX and nlopt until `brdf-fit export` fails.  The judge runs
# Blender's half there, in a subprocess.  `make venv` and `make test` never install it.
BLENDER_VENV := .venv-blender
BLENDER_STAMP := $(BLENDER_VENV)/.installed

blender: $(BLENDER_STAMP) $(DEV_STAMP)

$(BLENDER_STAMP):
	$(PYTHON) -m venv $(BLENDER_VENV)
	@echo "installing Blender's bpy into $(BLENDER_VENV) (pip; a 374 MB download the first time)"
	PYTHONWARNINGS=ignore $(BLENDER_VENV)/bin/python -m pip install -q 'bpy>=5.0,<6'
	touch $(BLENDER_STAMP)

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
	rm -rf $(VENV) $(BLENDER_VENV) demo-output .pytest_cache node_modules
