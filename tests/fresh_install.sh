#!/usr/bin/env bash
# The wheel as a new user meets it: installed into a fresh virtual environment of the oldest
# supported Python and of the newest one this machine has, with the newest dependencies the
# ranges in pyproject.toml allow (no lock), then a short take rendered, tracked and exported.
# A release of a dependency that breaks hullcap fails here, not on a user's machine.
#
#   tests/fresh_install.sh dist/hullcap-*.whl
set -euo pipefail
wheel=$(realpath "${1:?usage: tests/fresh_install.sh WHEEL}")
unset PIP_CONSTRAINT VIRTUAL_ENV  # the newest allowed, not the lock

# A Python of version $1: on PATH, or one of pyenv's (whose shims answer only for its global one).
find_python() {
  local v=$1 candidate
  for candidate in "python$v" "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"$v"*/bin/"python$v"; do
    if command -v "$candidate" >/dev/null 2>&1 && "$candidate" -c 'pass' >/dev/null 2>&1; then
      command -v "$candidate"
      return 0
    fi
  done
  return 1
}

oldest=$(find_python 3.11) || { echo "fresh install: no Python 3.11, the oldest supported"; exit 1; }
pythons=("$oldest")
for v in 3.14 3.13 3.12; do
  if newest=$(find_python "$v"); then pythons+=("$newest"); break; fi
done
[ ${#pythons[@]} -gt 1 ] || echo "fresh install: no Python newer than 3.11 on this machine; 3.11 only"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for python in "${pythons[@]}"; do
  version=$("$python" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  echo "== fresh install: $wheel on Python $version ($python)"
  env="$work/venv-$version"
  "$python" -m venv "$env"
  "$env/bin/python" -m pip install --quiet --disable-pip-version-check "$wheel"
  "$env/bin/python" -m pip check
  "$env/bin/python" -c 'import cv2, numpy, scipy, hullcap
print(f"hullcap {hullcap.__version__}: numpy {numpy.__version__}, scipy {scipy.__version__}, OpenCV {cv2.__version__}")'
  seq="$work/take-$version" out="$work/out-$version"
  "$env/bin/hullcap" synth "$seq" --cameras 6 --frames 24 --seed 1 >/dev/null 2>&1
  "$env/bin/hullcap" track "$seq" --out "$out" --no-overlays 2>/dev/null | tail -n 1
  "$env/bin/hullcap" export "$out" --format trc
  "$env/bin/hullcap" compare "$out" "$seq" | tail -n 2
done
echo "fresh install: passed on ${#pythons[@]} Python version(s)"
