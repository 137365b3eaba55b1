#!/usr/bin/env bash
# The Python client's tests against a real cleave-server, as a user would
# install the client: a fresh virtual environment (target/python-tests),
# `pip install ./client/python[test]` (the gRPC stubs are generated from
# proto/cleave.proto while it builds), then pytest. The tests start the
# server and the embedded runs from target/release (or $CLEAVE_BIN_DIR).
# Needs Python 3.10+ with venv and pip, and PyPI.
set -euo pipefail
cd "$(dirname "$0")/../.."
# the binaries: $CLEAVE_BIN_DIR's as they are (.ci/run passes the ones
# `cargo test --release --workspace` has just built: a `cargo build` here
# would rebuild them, as tests unify other features), else built now
if [ -z "${CLEAVE_BIN_DIR:-}" ]; then
    cargo build --release --workspace --bins
fi
python3 -c 'import sys; sys.exit(sys.version_info < (3, 10))' ||
    { echo "the Python client needs Python 3.10 or newer" >&2; exit 1; }
venv=target/python-tests
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check "./client/python[test]"
CLEAVE_BIN_DIR="${CLEAVE_BIN_DIR:-$PWD/target/release}" \
    "$venv/bin/python" -m pytest -q -p no:cacheprovider client/python/tests "$@"
