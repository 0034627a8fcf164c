#!/usr/bin/env bash
# Set up fmuid on a fresh Debian/Ubuntu machine: system packages, a virtual environment with the
# dependencies pinned by constraints.txt, the package itself, and the built-in FMUs (compiled from model_src/).
#   bash scripts/setup.sh          # what `fmuid demo` and `fmuid serve` need
#   bash scripts/setup.sh --test   # plus the test tools (headless Chromium for the report test)
set -euo pipefail
cd "$(dirname "$0")/.."

want_test=0
[ "${1:-}" = "--test" ] && want_test=1

apt_install() {
    local missing=()
    for pkg in "$@"; do dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg"); done
    [ ${#missing[@]} -eq 0 ] && return 0
    if [ "$(id -u)" -ne 0 ]; then
        echo "setup: please install these Debian packages: ${missing[*]}" >&2
        return 1
    fi
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
}

apt_install gcc libc6-dev python3-venv
if [ "$want_test" = 1 ]; then
    apt_install chromium chromium-driver
fi

if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/python -m pip install -q --upgrade pip
# Exact versions from constraints.txt; pyproject.toml only states the compatible ranges.
if [ "$want_test" = 1 ]; then
    .venv/bin/python -m pip install -q -c constraints.txt -e '.[dev]'
else
    .venv/bin/python -m pip install -q -c constraints.txt -e '.[service,dask,report]'
fi
.venv/bin/fmuid build-fmus
