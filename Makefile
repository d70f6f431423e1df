# Two commands on a fresh machine (only python3 >= 3.11 and make needed):
#   make run    set up .venv and start the service on the embedded default (SQLite, job processes it supervises)
#   make test   set up .venv and run the whole test suite
# Both install the versions pinned in requirements/*.txt (with hashes), written by `make lock` from
# pyproject.toml: `make run` the service with every kind (requirements/service.txt), `make test` that plus
# scaled mode and the test tools (requirements/test.txt). The installer is uv, pinned below and set up
# into .tools/ by pip; packages come from its cache (~/.cache/uv) after the first install.
PYTHON     ?= python3
VENV       ?= .venv
BIN        := $(VENV)/bin
HOST       ?= 127.0.0.1
PORT       ?= 8000
TEST_WORKERS ?= 2
UV_VERSION := 0.13.8
UV         := .tools/bin/uv
# never let uv fetch a Python of its own: the venv is made with $(PYTHON)
export UV_PYTHON_DOWNLOADS := never
# what `make lock` resolves for: the Python and platform of the machines, CI and the image
LOCK_FLAGS := --python-version 3.11 --python-platform x86_64-manylinux_2_36 --generate-hashes --quiet

.PHONY: install install-service run test test-fast bench worker migrate lock clean

$(UV):
	$(PYTHON) -m pip install --quiet --disable-pip-version-check --root-user-action=ignore --target .tools uv==$(UV_VERSION)

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# one stamp per installed set: each install is the lock's exact versions, then plantsolve itself (editable).
# Compiled to bytecode at install (uv's default is not to): where no process may write __pycache__
# (PYTHONDONTWRITEBYTECODE, a read-only install) every process would compile each module it imports, seconds
# of CPU for each `plantsolve solve` and each job process.
$(VENV)/.installed-%: requirements/%.txt pyproject.toml | $(UV) $(BIN)/python
	$(UV) pip install --quiet --python $(BIN)/python --require-hashes --compile-bytecode -r requirements/$*.txt
	$(UV) pip install --quiet --python $(BIN)/python --no-deps -e .
	$(BIN)/python -m compileall -q plantsolve
	touch $@

# everything the tests need (a developer's install)
install: $(VENV)/.installed-test

# the service alone: every kind, no test tools
install-service: $(VENV)/.installed-service

run: install-service
	$(BIN)/plantsolve serve --host $(HOST) --port $(PORT)

# the suite over TEST_WORKERS processes (pytest-xdist); the integration tests stay together on one of them. The
# OpenAPI contract test runs beside it in a process of its own (schemathesis' generated items share one node id,
# which pytest-xdist's scheduler would run once instead of once per operation): it takes the cores while the suite
# waits on its jobs, servers and subprocesses, and its output is printed after the suite's.
# PYTHONDONTWRITEBYTECODE is lifted for the tests: pytest then keeps each test module's assertion-rewritten bytecode
# in __pycache__, where each process of each later run reads it instead of parsing, rewriting and compiling ~47,000
# lines again (about 12 of a worker's 21 CPU s of collection). The suite's processes load no schemathesis plugin: only
# the contract test uses it, and it costs each of them a third of a CPU second.
test: install
	@log=$$(mktemp); \
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest tests/app/test_schemathesis.py > $$log 2>&1 & contract=$$!; \
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadgroup \
		--ignore=tests/app/test_schemathesis.py -p no:schemathesis; suite=$$?; \
	wait $$contract; contract_status=$$?; cat $$log; rm -f $$log; \
	test $$suite -eq 0 && test $$contract_status -eq 0

# Everything but the PostgreSQL/Redis/Celery integration tests.
test-fast: install
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadgroup -m "not integration"

worker: install
	$(BIN)/plantsolve worker

migrate: install-service
	$(BIN)/plantsolve migrate

bench: install
	$(BIN)/python bench/api.py --quick
	$(BIN)/python bench/hostile.py
	@for b in alignment tube perfmap polyhedra flowmeter rigidity dedup blobs; do [ -f bench/$$b.py ] && $(BIN)/python bench/$$b.py --quick || true; done

# Re-pin after changing pyproject.toml's dependencies (needs the package index). The service and
# image sets take the test set's versions, so every set agrees on every package it shares.
lock: $(UV)
	$(UV) pip compile pyproject.toml --extra test $(LOCK_FLAGS) -o requirements/test.txt
	$(UV) pip compile pyproject.toml --extra kinds --extra scaled -c requirements/test.txt $(LOCK_FLAGS) -o requirements/image.txt
	$(UV) pip compile pyproject.toml --extra kinds -c requirements/test.txt $(LOCK_FLAGS) -o requirements/service.txt

clean:
	rm -rf $(VENV) .tools var *.egg-info
