#!/usr/bin/env bash
# A throwaway PostgreSQL cluster for the fleet tests (client/tests/fleet.rs).
#
#   bash .ci/postgres.sh --install   installs Debian's server package if no
#                                    initdb is found (CI; needs root)
#   bash .ci/postgres.sh start DIR   starts a cluster in DIR/cluster on
#                                    127.0.0.1 on a free port, trust
#                                    authentication, and prints its URL
#   bash .ci/postgres.sh stop DIR    stops it (immediately)
#   bash .ci/postgres.sh restart DIR restarts it (fast shutdown)
#
# The server runs as an unprivileged user (PostgreSQL refuses root): as the
# caller, or as `postgres` when the caller is root.
set -euo pipefail
find_bin() {
    command -v "$1" 2>/dev/null || ls /usr/lib/postgresql/*/bin/"$1" 2>/dev/null | sort -V | tail -1
}
as=()
[ "$(id -u)" = 0 ] && as=(runuser -u postgres --)
case "${1:-}" in
--install)
    if [ -z "$(find_bin initdb || true)" ]; then
        echo "installing PostgreSQL from Debian's packages" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get install -y -q postgresql >&2 || { apt-get update -q >&2 && apt-get install -y -q postgresql >&2; }
    fi
    find_bin initdb >/dev/null
    ;;
start)
    dir="$2"
    initdb="$(find_bin initdb || true)"
    [ -n "$initdb" ] || { echo "no PostgreSQL server (initdb) on this machine" >&2; exit 3; }
    mkdir -p "$dir/cluster"
    if [ "$(id -u)" = 0 ]; then
        id postgres >/dev/null 2>&1 || useradd --system --no-create-home postgres
        chmod 755 "$dir"
        chown postgres "$dir/cluster"
    fi
    port="$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"
    "${as[@]}" "$initdb" -D "$dir/cluster" -U cleave --auth=trust -E UTF8 >"$dir/initdb.log" 2>&1 \
        || { cat "$dir/initdb.log" >&2; exit 1; }
    echo "port = $port" >>"$dir/cluster/postgresql.conf"
    cat >>"$dir/cluster/postgresql.conf" <<CONF
listen_addresses = '127.0.0.1'
unix_socket_directories = ''
max_connections = 200
fsync = off
CONF
    "${as[@]}" "$(dirname "$initdb")/pg_ctl" -D "$dir/cluster" -w -t 60 -l "$dir/cluster/server.log" start >&2
    echo "postgres://cleave@127.0.0.1:$port/postgres"
    ;;
stop | restart)
    pg_ctl="$(dirname "$(find_bin initdb)")/pg_ctl"
    mode=immediate
    [ "$1" = restart ] && mode=fast
    "${as[@]}" "$pg_ctl" -D "$2/cluster" -w -t 60 -m "$mode" -l "$2/cluster/server.log" "$1" >&2
    ;;
*)
    echo "usage: $0 --install | start DIR | stop DIR | restart DIR" >&2
    exit 2
    ;;
esac
