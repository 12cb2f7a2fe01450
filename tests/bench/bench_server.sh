# Sourced by the benchmark scripts (not run): a fresh output folder with a token secret, and a
# terrain-server on an ephemeral port.
#   bench_folder DIR                 out=DIR, emptied; TERRAIN_TOKEN_SECRET set for this run
#   start_server LOG BINARY ARGS...  BINARY serve ARGS --port 0, its output in LOG; sets server
#                                    (the pid) and port once it listens; exits 1 if it does not
#   stop_server                      SIGTERM, then waits for it to drain

bench_folder() {
    out=$1
    rm -rf "$out"
    mkdir -p "$out"
    TERRAIN_TOKEN_SECRET="bench-$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')"
    export TERRAIN_TOKEN_SECRET
}

start_server() {
    local log=$1 binary=$2
    shift 2
    rm -f "$out/port"
    "$binary" serve --port 0 --port-file "$out/port" "$@" > "$log" 2>&1 &
    server=$!
    for _ in $(seq 1 300); do
        [ -s "$out/port" ] && break
        kill -0 "$server" 2> /dev/null || break
        sleep 0.1
    done
    if [ ! -s "$out/port" ]; then
        echo "the server did not start:"
        cat "$log"
        exit 1
    fi
    port=$(cat "$out/port")
}

stop_server() {
    kill -TERM "$server" 2> /dev/null || true
    wait "$server" || true
}
