# Two commands on a fresh machine (only python3 >= 3.11 and make needed):
#   make run    set up .venv and start the service on the embedded default (SQLite, job processes it supervises)
#   make test   set up .venv and run the whole test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
HOST   ?= 127.0.0.1
PORT   ?= 8000

.PHONY: install run test test-fast bench worker migrate clean

$(BIN)/plantsolve: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

install: $(BIN)/plantsolve

run: install
	$(BIN)/plantsolve serve --host $(HOST) --port $(PORT)

test: install
	$(BIN)/python -m pytest

# Everything but the PostgreSQL/Redis/Celery integration tests.
test-fast: install
	$(BIN)/python -m pytest -m "not integration"

worker: install
	$(BIN)/plantsolve worker

migrate: install
	$(BIN)/plantsolve migrate

bench: install
	$(BIN)/python bench/api.py --quick
	@for b in alignment tube perfmap polyhedra flowmeter rigidity dedup; do [ -f bench/$$b.py ] && $(BIN)/python bench/$$b.py --quick || true; done

clean:
	rm -rf $(VENV) var *.egg-info
