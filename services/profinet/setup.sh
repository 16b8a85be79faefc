#!/usr/bin/env bash
# Creates the Python environment of the PROFINET system tests: profinet-py (PyPI, GPL-3.0),
# run only as an external IO-controller tool, never linked or vendored. It goes to
# target/profinet-venv of the repository (PROFINET_PY_VENV overrides). Safe to run again.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
venv="${PROFINET_PY_VENV:-$repo/target/profinet-venv}"

if ! python3 -m venv --help >/dev/null 2>&1; then
    echo "services/profinet/setup.sh: python3 with the venv module is needed (Debian: apt-get install python3-venv)" >&2
    exit 1
fi
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
# The version the DCP system test was written against.
if ! "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "profinet-py==0.6.6"; then
    echo "services/profinet/setup.sh: pip could not install profinet-py (is the package index reachable?)" >&2
    exit 1
fi
echo "profinet-py ready: $venv/bin/profinet"
