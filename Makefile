# armtrack: `make demo` and `make test` set everything up on a fresh machine.
# Both install the exact versions the suite passed with (requirements.lock, made by `make lock`);
# pyproject.toml keeps compatible ranges for people who `pip install` armtrack elsewhere.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
LOCK := requirements.lock
DEMO := sample_sessions/circle-01
DEMO_OUT := demo-out

.PHONY: setup demo test test-latest lock lint bench bench-sessions validate docs samples clean

$(STAMP): pyproject.toml $(LOCK)
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet -c $(LOCK) pip setuptools wheel
	$(BIN)/python -m pip install --quiet --no-build-isolation -c $(LOCK) -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/armtrack info $(DEMO)
	$(BIN)/armtrack run $(DEMO) --method ekf --method pf-constraint --method arm-smoother --out $(DEMO_OUT)/circle-01
	$(BIN)/armtrack info sample_sessions/wrist-rom-01
	$(BIN)/armtrack run sample_sessions/reach-01 sample_sessions/wrist-rom-01 --out $(DEMO_OUT)
	$(BIN)/armtrack simulate $(DEMO_OUT)/sessions/circle-02 --seed 5 --recorded 2026-11-27T10:15:00 --force
	$(BIN)/armtrack run $(DEMO_OUT)/sessions/circle-02 --out $(DEMO_OUT)/circle-02
	$(BIN)/armtrack report $(DEMO) $(DEMO_OUT)/sessions/circle-02 --out $(DEMO_OUT) \
		-o $(DEMO_OUT)/progress-SIM.pdf
	@echo "demo: outputs and reports (report.pdf in each folder, progress-SIM.pdf) in $(DEMO_OUT)/"

samples: $(STAMP)
	$(BIN)/armtrack simulate sample_sessions/circle-01 --seed 1 --gt-gaps 2 --force
	$(BIN)/armtrack simulate sample_sessions/reach-01 --task reach --seed 2 --duration 12 \
		--drop-rate 0.01 --imu-format mcap --force
	$(BIN)/armtrack simulate sample_sessions/wrist-rom-01 --task wrist-rom --seed 3 --duration 12 --force

test: $(STAMP)  # the slowest tests listed at the end: where the ~12 minutes go
	$(BIN)/python -m pytest -q -p no:cacheprovider --durations=15

# The suite against the newest versions pyproject.toml allows, in a venv of its own.
test-latest:
	rm -rf .venv-latest
	$(PY) -m venv .venv-latest
	.venv-latest/bin/python -m pip install --quiet --upgrade pip setuptools wheel
	.venv-latest/bin/python -m pip install --quiet --no-build-isolation -e '.[dev]'
	.venv-latest/bin/python -m pytest -q -p no:cacheprovider

# Regenerate the lock: the newest allowed versions, written only if the suite passes with them.
lock: test-latest
	{ echo "# Exact versions the test suite passed with (Python $$(.venv-latest/bin/python -c \
	'import platform; print(platform.python_version())'), $$(date -u +%Y-%m-%d)); made by \`make lock\`."; \
	  .venv-latest/bin/python -m pip freeze --all --exclude-editable | LC_ALL=C sort -f; } > $(LOCK).tmp
	mv $(LOCK).tmp $(LOCK)
	rm -rf .venv-latest

lint: $(STAMP)
	$(BIN)/ruff check armtrack_cli tests

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py
	$(BIN)/python benchmarks/palm.py

# The long simulated sessions `make bench` uses, ahead of it (kept in build/bench-sessions/ until
# the simulator changes; the 10-minute one takes minutes, the 60-minute one is six copies of it
# back to back, benchmarks/tiling.py, whose video takes ~10 minutes to re-encode)
bench-sessions: $(STAMP)
	$(BIN)/python benchmarks/sessions.py 1 10
	$(BIN)/python -c "import sys; sys.path.insert(0, 'benchmarks'); from sessions import tiled_session; print(tiled_session(6))"

validate: $(STAMP)
	ARMTRACK_FUZZ_EXAMPLES=2000 $(BIN)/python -m pytest -q -p no:cacheprovider tests/test_fuzz_readers.py
	$(BIN)/python validation/run.py
	$(BIN)/python validation/smoother_bias.py
	$(BIN)/python validation/palm.py
	$(BIN)/python validation/ue_adl.py
	$(BIN)/python validation/path_measures.py
	$(BIN)/python validation/detect_distractor.py
	$(BIN)/python validation/from_mocap.py
	$(BIN)/python validation/imu_sync.py
	$(BIN)/python validation/arm_auto.py
	$(BIN)/python validation/arm_auto_tape.py
	$(BIN)/python validation/forward_filter.py

docs: $(STAMP)
	$(BIN)/python -c "from armtrack_cli.cli import render_reference as r; open('docs/cli.md','w').write(r())"

clean:
	rm -rf $(VENV) .venv-latest $(DEMO_OUT) *.egg-info
