#!/bin/bash
# One PostgreSQL server for all db test processes (the ctest fixture history_pg): started
# before them, stopped after. Unix socket only, in DIR; as root the server runs as nobody
# (initdb refuses root). The tests read DIR/server ("SOCKET_DIR PORT"); without it each test
# process starts a server of its own.
#   pg-server.sh start|stop DIR
set -eu
cmd=$1 dir=$2
bin=$(find /usr/lib/postgresql -maxdepth 2 -name bin -type d | sort -V | tail -n 1)
[ -x "$bin/initdb" ] || { echo "PostgreSQL is not installed (package postgresql)" >&2; exit 1; }
as=()
[ "$(id -u)" = 0 ] && as=(runuser -u nobody --)
stop() {
  [ -d "$dir/data" ] && "${as[@]}" "$bin/pg_ctl" -D "$dir/data" -m fast -w stop >/dev/null 2>&1 || true
}
case $cmd in
  start)
    stop  # a server a killed run left behind
    rm -rf "$dir"
    mkdir -p "$dir"
    [ ${#as[@]} = 0 ] || chown nobody "$dir"
    port=$((20000 + ($$ * 2 + 1) % 20000))
    "${as[@]}" "$bin/initdb" -D "$dir/data" -A trust -U circtest --no-sync -E UTF8 >"$dir/setup.log" 2>&1 ||
      { cat "$dir/setup.log" >&2; exit 1; }
    "${as[@]}" "$bin/pg_ctl" -D "$dir/data" -l "$dir/log" -w \
      -o "-k $dir -p $port -c listen_addresses='' -c fsync=off -c max_connections=200" start >>"$dir/setup.log" 2>&1 ||
      { cat "$dir/setup.log" "$dir/log" >&2; exit 1; }
    echo "$dir $port" >"$dir/server"
    echo "PostgreSQL for the db tests: socket $dir, port $port"
    ;;
  stop)
    stop
    rm -rf "$dir"
    ;;
  *) echo "usage: pg-server.sh start|stop DIR" >&2; exit 2 ;;
esac
