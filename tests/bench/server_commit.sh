#!/usr/bin/env bash
# A real terrain-server process with the fsync journal, fed over TCP by one deformer
# (battle_feed): battle_bench's battle ops windowed (64 in flight: throughput), then paced at
# 600 ops/s (latency), with N light viewers (terrain-bot processes holding replicas) watching.
# Prints battle_feed's lines. Usage: bash tests/bench/server_commit.sh [server binary] [shots]
# [viewers] (defaults: build/release/server/terrain-server, 4000, 4). Needs build/release.
set -euo pipefail
cd "$(dirname "$0")/../.."
server_bin=${1:-build/release/server/terrain-server}
shots=${2:-4000}
viewers=${3:-4}
bin=build/release
# shellcheck source=tests/bench/bench_server.sh
source tests/bench/bench_server.sh
bench_folder out/bench/server_commit
"$bin/tests/battle_bench" --shots "$shots" --ops "$out/ops.txt" > /dev/null
run() { # name feed-options...
    local name=$1
    shift
    rm -rf "$out/data"
    start_server "$out/server-$name.log" "$server_bin" --data-dir "$out/data" --deform-rate 100000
    local pids=()
    for v in $(seq 1 "$viewers"); do
        "$bin/client/bot/terrain-bot" --connect "127.0.0.1:$port" --name "v$v" \
            --token "$("$server_bin" token --player $((10 + v)) --role viewer)" \
            --frames 1 --craters 0 --settle 3 --report "$out/v$v.json" \
            > /dev/null 2>&1 &
        pids+=($!)
    done
    sleep 1
    echo -n "$name: "
    "$bin/tests/battle_feed" --port "$port" --ops "$out/ops.txt" "$@" \
        --token "$("$server_bin" token --player 1 --role deformer)"
    for p in "${pids[@]}"; do wait "$p" || true; done
    stop_server
}
run windowed --window 64
run paced-600 --rate 600
