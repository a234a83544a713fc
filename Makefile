# The README's two commands:  `make demo`  and  `make test`.
# Each sets up what it needs: a virtualenv in .venv with the package and its
# dev extra, and (for headless OpenGL) Mesa's EGL through apt where missing.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
NODE_STAMP := node_modules/.installed

.PHONY: test demo venv sysdeps clean

test: $(STAMP) $(NODE_STAMP) sysdeps
	$(PY) -m pytest -q

demo: $(STAMP) sysdeps
	$(VENV)/bin/brdf-fit demo --out demo-output

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP)

# The Khronos glTF validator (npm gltf-validator) for the export tests, into
# ./node_modules; without node/npm those tests skip and say why.
$(NODE_STAMP): package.json package-lock.json
	@if command -v npm >/dev/null 2>&1; then \
		npm ci --no-audit --no-fund && touch $(NODE_STAMP) \
			|| echo "npm ci failed: the glTF validator tests will be skipped"; \
	else \
		echo "npm not found: the glTF validator tests will be skipped"; \
	fi

sysdeps:
	@bash .ci/install-system-packages

clean:
	rm -rf $(VENV) demo-output .pytest_cache node_modules
