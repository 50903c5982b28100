# Two set-up commands work on a fresh machine: `make demo` and `make test`.
# Each creates .venv and installs what is missing (apt packages included) first. Debian's chromium is the
# browser of the report's browser tests (tests/report/test_browser.py, through pytest-playwright; Playwright's own
# browser download is never used).
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
APT_PKGS := libusb-1.0-0 gdal-bin gcc chromium
DEMO_OUT ?= demo-out
LOCK    := requirements.lock
LOCK_ROTORPY := requirements-rotorpy.lock

.PHONY: demo test install native sysdeps lint bench clean goldens lock

# the per-step kernel compiled with mypyc (vinecli/native.py); rebuilt when one of its sources changes
KERNEL_SRC := $(addprefix vinecli/,$(shell grep -o '^    "[a-z_/]*\.py",' vinecli/native.py | tr -d '", '))
NATIVE  := vinecli/native.json

# requirements.lock: every package of `.[dev]` and of the build (requirements-build.in: hatchling, mypy,
# setuptools) pinned with its hashes for Python 3.11 (`make lock`); vinecli itself installs editable on top,
# built from those (no build isolation, so nothing unhashed is fetched)
$(STAMP): pyproject.toml $(LOCK) $(LOCK_ROTORPY)
	@$(MAKE) --no-print-directory sysdeps
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/pip install -q --require-hashes -r $(LOCK)
	$(BIN)/pip install -q --no-deps --no-build-isolation -e .
	# RotorPy, the reference simulator of tests/sim/test_rotorpy_agreement.py, without its optional dependencies
	$(BIN)/pip install -q --require-hashes --no-deps -r $(LOCK_ROTORPY)
	touch $(STAMP)

install: $(STAMP)

# after a change of pyproject.toml's dependencies, requirements-build.in or requirements-rotorpy.in: resolve and
# hash them again for Python 3.11 (uv in a venv of its own; pip installs the result) and commit both .lock files
UV := build/uv/bin/uv
lock:
	test -x $(UV) || ($(PY) -m venv build/uv && build/uv/bin/pip install -q 'uv==0.13.8')
	$(UV) pip compile -q pyproject.toml requirements-build.in --extra dev --generate-hashes --python-version 3.11 \
	  --no-header -o $(LOCK)
	$(UV) pip compile -q $(LOCK_ROTORPY:.lock=.in) --no-deps --generate-hashes --python-version 3.11 --no-header \
	  -o $(LOCK_ROTORPY)

$(NATIVE): $(STAMP) $(KERNEL_SRC) vinecli/native.py scripts/build_native.py
	$(BIN)/python scripts/build_native.py

native: $(NATIVE)

sysdeps:
	@missing=""; for p in $(APT_PKGS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing system packages:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing >/dev/null; \
	fi

# on every core (pytest-xdist); tests/conftest.py runs each module on one worker and the firmware tests one after
# the other on one (tests/xdist_scopes.py); the worlds several modules need are built once for all workers
test: $(STAMP) $(NATIVE)
	$(BIN)/python -m pytest -q -n auto

# after a deliberate change of what runs produce: fly the golden runs on both kernels, rewrite
# tests/golden/goldens.json and print what moved (commit it on its own, saying what moved and by how much)
goldens: $(STAMP) $(NATIVE)
	$(BIN)/python tests/golden/golden_runs.py

demo: $(STAMP) $(NATIVE)
	bash scripts/demo.sh $(DEMO_OUT)

lint: $(STAMP)
	$(BIN)/ruff check vinecli tests benchmarks

bench: $(STAMP) $(NATIVE)
	for b in terrain reconstruct physics sim loop_parts autopilot_step deposition batch report seeds; do $(BIN)/python benchmarks/$$b.py || exit 1; done

clean:
	rm -rf $(DEMO_OUT) .pytest_cache build/native $(NATIVE)
	find vinecli -name '*.so' -delete
