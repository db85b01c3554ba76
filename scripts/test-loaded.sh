#!/usr/bin/env bash
# The whole pytest suite beside a CPU hog that keeps every core busy (stress-ng), the way
# a user's laptop or a shared CI runner is: `make test-loaded`. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v stress-ng >/dev/null || { echo "stress-ng is missing: run make sysdeps" >&2; exit 1; }
stress-ng --cpu "$(nproc)" --timeout 0 --quiet &
hog=$!
trap 'kill "$hog" 2>/dev/null; wait "$hog" 2>/dev/null || true' EXIT
echo "simbridge: pytest beside stress-ng --cpu $(nproc) (pid $hog)"
.venv/bin/pytest "$@"
