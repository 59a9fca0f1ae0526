# The README's two commands are `make demo` and `make test`; both set everything up.
#   make demo    build the engine (release) in .venv and run the demo
#   make test    build the engine, then cargo test + pytest
#   make bench   benchmarks against SciPy / pykdtree (installs the `bench` extra)
#   make wheel   a release wheel in dist/

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
export VIRTUAL_ENV := $(abspath $(VENV))

ENGINE_SOURCES := Cargo.toml pyproject.toml $(wildcard Cargo.lock) \
                  $(shell find crates -name '*.rs' -o -name Cargo.toml)
EXTRAS ?= test
comma  := ,
# One stamp per set of extras, so `make bench` installs its peers even after `make test`.
ENGINE := $(VENV)/.engine-$(subst $(comma),-,$(EXTRAS))

.PHONY: demo test bench wheel engine clean

demo: $(ENGINE)
	$(PY) benchmarks/bench_kdtree.py --quick

test: $(ENGINE)
	cargo test
	$(PY) -m pytest -q

bench:
	$(MAKE) engine EXTRAS=test,bench
	$(PY) benchmarks/bench_kdtree.py

wheel: $(PY)
	$(VENV)/bin/maturin build --release --out dist

engine: $(ENGINE)

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip 'maturin>=1.9.4,<2'

# Rebuilt whenever a Rust source or the manifests change; a stale extension next to the
# Python sources would shadow the new one, so it goes first.
$(ENGINE): $(PY) $(ENGINE_SOURCES)
	rm -f python/hullcap/_engine*.so $(VENV)/.engine-*
	$(VENV)/bin/maturin develop --release --extras $(EXTRAS)
	touch $@

clean:
	rm -rf $(VENV) target dist python/hullcap/_engine*.so
