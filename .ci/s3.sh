#!/usr/bin/env bash
# A throwaway S3-compatible endpoint for the fleet tests
# (client/tests/fleet.rs): moto's server, from PyPI.
#
#   bash .ci/s3.sh --install    pip-installs moto[server] if python3 lacks it
#   bash .ci/s3.sh start DIR    starts one on 127.0.0.1 on a free port, with
#                               an empty bucket `cleave-test`, and prints
#                               its endpoint URL
#   bash .ci/s3.sh stop DIR     stops it
#
# moto accepts any credentials; the servers under test are given
# AWS_ENDPOINT=URL AWS_ALLOW_HTTP=true and dummy keys.
set -euo pipefail
# (the module, not the moto_server script: a fresh pip install's script
# may not be on PATH yet, behind pyenv's shims)
have_moto() { python3 -c 'import moto.server, flask' >/dev/null 2>&1; }
case "${1:-}" in
--install)
    if ! have_moto; then
        echo "installing moto[server] from PyPI" >&2
        python3 -m pip install -q 'moto[server]' >&2
    fi
    have_moto
    ;;
start)
    dir="$2"
    have_moto || { echo "no moto[server] for python3 on this machine" >&2; exit 3; }
    mkdir -p "$dir"
    port="$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
    url="http://127.0.0.1:$port"
    nohup python3 -m moto.server -H 127.0.0.1 -p "$port" >"$dir/moto.log" 2>&1 &
    echo $! >"$dir/moto.pid"
    python3 - "$url" <<'PY' || { cat "$dir/moto.log" >&2; exit 1; }
import sys, time, urllib.request
url = sys.argv[1]
for _ in range(300):
    try:
        urllib.request.urlopen(urllib.request.Request(url + "/cleave-test", method="PUT"), timeout=2)
        sys.exit(0)
    except OSError:
        time.sleep(0.1)
sys.exit("moto_server did not answer in 30 s")
PY
    echo "$url"
    ;;
stop)
    [ -f "$2/moto.pid" ] && kill "$(cat "$2/moto.pid")" 2>/dev/null || true
    ;;
*)
    echo "usage: $0 --install | start DIR | stop DIR" >&2
    exit 2
    ;;
esac
