#!/usr/bin/env bash
# Creates the Python environment of `rc bench motion`'s reference planners (ruckig, toppra)
# and of the lines' jerk-limited optimum (CasADi) under target/bench-venv of the repository.
# Safe to run again: it only adds what is missing.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${RC_BENCH_VENV:-$repo/target/bench-venv}"

if ! python3 -m venv --help >/dev/null 2>&1; then
    echo "bench/setup.sh: python3 with the venv module is needed (Debian: apt-get install python3-venv)" >&2
    exit 1
fi
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
# Versions known to work with bench/reference.py; newer ones may be tried with
# RC_BENCH_UNPINNED=1.
if [ "${RC_BENCH_UNPINNED:-0}" = "1" ]; then
    packages=(ruckig toppra)
    optimum=(casadi)
else
    packages=("ruckig==0.19.4" "toppra==0.6.10")
    optimum=("casadi==3.7.2")
fi
if ! "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "${packages[@]}"; then
    echo "bench/setup.sh: pip could not install ${packages[*]} (is the package index reachable?);" \
        "rc bench motion will skip the optimality rows" >&2
    exit 1
fi
"$venv/bin/python" -c 'import importlib.metadata as m, ruckig, toppra; print("ruckig", m.version("ruckig"), "toppra", m.version("toppra"))'
# The optimum is a further row: without CasADi the others still run.
if "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "${optimum[@]}"; then
    "$venv/bin/python" -c 'import importlib.metadata as m, casadi; print("casadi", m.version("casadi"))'
else
    echo "bench/setup.sh: pip could not install ${optimum[*]}; rc bench motion will report" \
        "the jerk-limited optimum as failed (or skip it with --optimum-lines 0)" >&2
fi
echo "reference environment ready: $venv/bin/python"
