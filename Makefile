# The README's two commands are `make demo` and `make test`; both set everything up.
#   make demo    build the engine (release) into .venv and run the demo
#   make test    the same set-up, then cargo test + pytest
#   make bench   every benchmark, with its reference peers (SciPy, pykdtree, Open3D), and the
#                development set last (where it is: benchmarks/devset.py)
#   make paper   the paper's evaluation: plots and docs/paper.md
#   make wheel   the release wheel in dist/: abi3 (every CPython >= 3.11), manylinux2014
#   make check-wheel  that wheel installed into fresh virtual environments of the oldest and newest
#                Python found, with the newest dependencies its ranges allow, tracking a take
#   make test-lowest  make test in .venv-lowest, every dependency at the lowest version allowed
#   make lock    resolve requirements/lock.txt (newest allowed) and lowest.txt again
#   make segment-models  the learned segmenter's model files, as a package (every set-up above does it)
#
# Every pip install here is constrained by the lock (PIP_CONSTRAINT): a fresh machine gets the
# versions that were tested, whatever the registries hold today.

PYTHON ?= python3
VENV   ?= .venv
LOCK   ?= requirements/lock.txt
PY     := $(VENV)/bin/python
export VIRTUAL_ENV := $(abspath $(VENV))
export PIP_CONSTRAINT := $(abspath $(LOCK))

ENGINE_SOURCES := Cargo.toml pyproject.toml $(wildcard Cargo.lock) \
                  $(shell find crates -name '*.rs' -o -name Cargo.toml)
ENGINE := $(VENV)/.engine-built
MODELS := $(VENV)/.segment-models

.PHONY: demo test test-lowest bench paper docs wheel check-wheel lock engine segment-models no-rayon clean

demo: $(ENGINE)
	$(VENV)/bin/hullcap demo

test: $(ENGINE) no-rayon
	cargo test
	$(PY) -m pytest -q

bench: $(ENGINE)
	$(PY) benchmarks/bench_kdtree.py
	$(PY) benchmarks/bench_skin.py
	$(PY) benchmarks/bench_hull.py
	$(PY) benchmarks/bench_tracking.py
	$(PY) benchmarks/bench_tracking.py --accuracy
	$(PY) benchmarks/bench_batch.py
	$(PY) benchmarks/bench_scale.py   # HD cameras read at a fraction of their size, ~5 min
	$(PY) benchmarks/bench_devset.py --silhouettes colour exact   # the benchmark of record, ~8 min
	$(PY) benchmarks/bench_knee.py   # the subject model's knee search on the development set, ~10 min
	$(PY) benchmarks/bench_girdle.py   # raised arms in bench_devset's runs: the shoulders' height, refits, ~15 s
	$(PY) benchmarks/bench_real.py   # Pose2Sim's real take from its videos and calibration, ~2 min
	$(VENV)/bin/pip install --quiet open3d   # needs Debian's libusb-1.0-0
	$(PY) benchmarks/bench_icp.py

# The paper's evaluation (issue 6): plots and docs/paper.md, seeded.
paper: $(ENGINE)
	$(PY) benchmarks/paper.py

# The CLI reference, generated from the parser.
docs: $(ENGINE)
	COLUMNS=100 $(PY) -c "from hullcap._cli import reference; print(reference())" > docs/cli.md
	$(PY) -c "from hullcap._take import options_page; print(options_page())" > docs/options.md

test-lowest:
	$(MAKE) test VENV=.venv-lowest LOCK=requirements/lowest.txt

# One abi3 wheel serves every CPython >= 3.11; zig links it against glibc 2.17 (manylinux2014), so
# that it installs on the distributions labs run, not only on this machine's glibc.
wheel: $(PY)
	$(PY) -m pip install --quiet ziglang
	rm -f dist/hullcap-*.whl
	PATH="$(abspath $(VENV))/bin:$$PATH" $(VENV)/bin/maturin build --release --zig \
	  --compatibility manylinux2014 --out dist

check-wheel: wheel
	tests/fresh_install.sh dist/hullcap-*.whl

lock: $(PY)
	$(PY) -m pip install --quiet uv
	$(VENV)/bin/uv pip compile --quiet pyproject.toml requirements/tools.in --all-extras --universal \
	  --python-version 3.11 --upgrade -o requirements/lock.txt
	$(VENV)/bin/uv pip compile --quiet pyproject.toml requirements/tools.in --all-extras \
	  --resolution lowest-direct --python-version 3.11 --python-platform x86_64-manylinux_2_28 \
	  -o requirements/lowest.txt

engine: $(ENGINE)

# Threads come from std::thread::scope; rayon must not sneak in through a dependency.
no-rayon:
	@if cargo tree --workspace --prefix none | grep -q '^rayon'; then \
	  echo "rayon is in the dependency tree (cargo tree -i rayon)"; exit 1; fi

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip 'maturin>=1.9.4,<2'

# Rebuilt whenever a Rust source or a manifest changes. A stale extension next to the
# Python sources would shadow the new one, so it goes first. The `bench` extra brings the
# peers the demo and benchmarks compare against.
$(ENGINE): $(PY) $(ENGINE_SOURCES) $(MODELS)
	rm -f python/hullcap/_engine*.so
	$(VENV)/bin/maturin develop --release --extras test,bench,segment
	touch $@

# The learned segmenter's model files (hullcap[segment]): taken out of MediaPipe's wheel on PyPI,
# checked against its hash, and installed as the hullcap-segment-models package.
$(MODELS): $(PY) packages/segment-models/fetch.py packages/segment-models/pyproject.toml
	$(PY) packages/segment-models/fetch.py
	$(VENV)/bin/pip install --quiet ./packages/segment-models
	touch $@

segment-models: $(MODELS)

clean:
	rm -rf .venv .venv-lowest target dist python/hullcap/_engine*.so packages/segment-models/build \
	  packages/segment-models/*.egg-info packages/segment-models/hullcap_segment_models/*.tflite
