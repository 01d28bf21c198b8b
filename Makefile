# armtrack: `make demo` and `make test` set everything up on a fresh machine.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
DEMO := sample_sessions/circle-01
DEMO_OUT := demo-out

.PHONY: setup demo test lint bench validate docs samples clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/armtrack info $(DEMO)
	$(BIN)/armtrack calibrate $(DEMO) --out $(DEMO_OUT)/circle-01
	$(BIN)/armtrack detect $(DEMO) --out $(DEMO_OUT)/circle-01
	$(BIN)/armtrack fuse $(DEMO) --method ekf --out $(DEMO_OUT)/circle-01
	$(BIN)/armtrack fuse $(DEMO) --method pf-constraint --out $(DEMO_OUT)/circle-01
	$(BIN)/armtrack compare $(DEMO) --out $(DEMO_OUT)/circle-01
	$(BIN)/armtrack info sample_sessions/wrist-rom-01
	$(BIN)/armtrack calibrate sample_sessions/wrist-rom-01 --out $(DEMO_OUT)/wrist-rom-01
	$(BIN)/armtrack detect sample_sessions/wrist-rom-01 --out $(DEMO_OUT)/wrist-rom-01
	@echo "demo: outputs in $(DEMO_OUT)/"

samples: $(STAMP)
	$(BIN)/armtrack simulate sample_sessions/circle-01 --seed 1 --gt-gaps 2 --force
	$(BIN)/armtrack simulate sample_sessions/reach-01 --task reach --seed 2 --duration 12 \
		--drop-rate 0.01 --imu-format mcap --force
	$(BIN)/armtrack simulate sample_sessions/wrist-rom-01 --task wrist-rom --seed 3 --duration 12 --force

test: $(STAMP)
	$(BIN)/python -m pytest -q -p no:cacheprovider

lint: $(STAMP)
	$(BIN)/ruff check armtrack_cli tests

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py
	$(BIN)/python benchmarks/palm.py

validate: $(STAMP)
	$(BIN)/python validation/run.py

docs: $(STAMP)
	$(BIN)/python -c "from armtrack_cli.cli import render_reference as r; open('docs/cli.md','w').write(r())"

clean:
	rm -rf $(VENV) $(DEMO_OUT) *.egg-info
