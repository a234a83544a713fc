# The README's two commands:  `make demo`  and  `make test`.
# Each sets up what it needs: a virtualenv in .venv with the package and its
# dev extra, and (for headless OpenGL) Mesa's EGL through apt where missing.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: test demo venv sysdeps clean

test: $(STAMP) sysdeps
	$(PY) -m pytest -q

demo: $(STAMP) sysdeps
	$(VENV)/bin/brdf-fit demo --out demo-output

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP)

sysdeps:
	@bash .ci/install-system-packages

clean:
	rm -rf $(VENV) demo-output .pytest_cache
