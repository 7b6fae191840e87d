# Each target creates .venv and installs the project into it first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

.PHONY: demo test bench install
install: $(STAMP)

demo: $(STAMP)
	$(BIN)/planner plan scripts/tasks/puma560_paper_cartesian.yaml --out out/puma560_paper_cartesian

test: $(STAMP)
	$(BIN)/python -m pytest

bench: $(STAMP)
	$(BIN)/python scripts/bench_splines.py
	$(BIN)/python scripts/benchmark.py
	$(BIN)/python scripts/bench_ik.py
	$(BIN)/python scripts/bench_plan.py
	$(BIN)/python scripts/bench_scale.py
	$(BIN)/python scripts/bench_cartesian.py
	$(BIN)/python scripts/bench_robot_limits.py
