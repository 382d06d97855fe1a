# Two set-up commands (SPEC §3): `make demo` and `make test`.  Both start from python3 alone.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
DEMO_OUT := demo_report

.PHONY: demo test lint bench bytecode clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@ $(VENV)/.installed

# The demo: the estimator that works on the sample log (imm), then the paper-faithful HSTF
# beside it; report.md of hstf says why it scores lower (docs/three_tank.md has the study).
demo: $(VENV)/.installed bytecode
	@echo "== hybridlog analyze: the IMM estimator on the paper's three-tank run (sample_logs/) =="
	$(BIN)/hybridlog analyze sample_logs/three_tank_hstf.csv --model three_tank_hstf \
		--estimator imm --out $(DEMO_OUT)/imm --force
	@echo
	@echo "== hybridlog compare: the paper-faithful HSTF (paper 000) beside the IMM =="
	$(BIN)/hybridlog compare sample_logs/three_tank_hstf.csv --model three_tank_hstf \
		--estimators hstf,imm --out $(DEMO_OUT)/compare --force
	@echo
	@echo "Why the faithful HSTF scores lower (Notes of $(DEMO_OUT)/compare/hstf/report.md):"
	@$(BIN)/python -c "import json, sys, textwrap; \
		[print(textwrap.fill(n, 96, initial_indent='  ', subsequent_indent='  ')) \
		for n in json.load(open(sys.argv[1]))['notes']]" $(DEMO_OUT)/compare/hstf/report.json
	@echo
	@echo "Reports went to $(DEMO_OUT)/: imm/report.md, compare/comparison.md and one folder per"
	@echo "estimator (report.json, report.md, timeline.csv, estimates.csv, plots/)."
	@echo "Next: source $(BIN)/activate, then hybridlog --help; README.md has a tour."

lint: $(VENV)/.installed-test
	$(BIN)/ruff check hybridlog tests benchmarks docs/studies
	$(BIN)/ruff format --check hybridlog tests benchmarks docs/studies
	$(BIN)/mypy

test: lint bytecode
	$(BIN)/python -m pytest -n auto --durations=15

# Bytecode for the package's own modules: pip writes it for an installed copy, but this one is
# editable, and with PYTHONDONTWRITEBYTECODE set (as on the machines it is measured on) every
# command would compile them again (0.2-0.3 s per process).
bytecode: $(VENV)/.installed
	$(BIN)/python -m compileall -q hybridlog benchmarks

bench: $(VENV)/.installed-test bytecode
	$(BIN)/python -m benchmarks.run

clean:
	rm -rf $(VENV) $(DEMO_OUT) .pytest_cache .mypy_cache .ruff_cache
