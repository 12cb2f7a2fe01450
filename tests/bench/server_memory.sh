#!/usr/bin/env bash
# A real terrain-server process through a battle: battle_bench's 10,000 shots on the default map
# (its --ops) fed over TCP by one deformer (battle_feed), with the fsync journal, then a late
# joiner that ships the map and one that does not (both join caches built). Prints the server's
# resident set (VmRSS) and peak (VmHWM) after the battle and after the joins, as JSON.
# Usage: bash tests/bench/server_memory.sh [shots] (default 10000). Needs build/release.
set -euo pipefail
cd "$(dirname "$0")/../.."
shots=${1:-10000}
bin=build/release
# shellcheck source=tests/bench/bench_server.sh
source tests/bench/bench_server.sh
bench_folder out/bench/server_memory
"$bin/tests/battle_bench" --shots "$shots" --ops "$out/ops.txt" > "$out/battle_bench.json"
start_server "$out/server.log" "$bin/server/terrain-server" --data-dir "$out/data" \
    --deform-rate 100000
trap 'kill $server 2> /dev/null || true' EXIT
memory() { # VmRSS and VmHWM of the server, MiB
    awk '/^VmRSS|^VmHWM/ { sub(":", "", $1); printf "\"%s_mib\": %.1f, ", $1, $2 / 1024 }' \
        "/proc/$server/status" | sed 's/, $//'
}
idle=$(memory)
"$bin/tests/battle_feed" --port "$port" --ops "$out/ops.txt" \
    --token "$("$bin/server/terrain-server" token --player 1 --role deformer)"
battle=$(memory)
viewer=$("$bin/server/terrain-server" token --player 2 --role viewer)
"$bin/client/bot/terrain-bot" --connect "127.0.0.1:$port" --token "$viewer" --name shipped \
    --map --frames 1 --craters 0 --settle 0.2 --report "$out/shipped.json" > /dev/null
"$bin/client/bot/terrain-bot" --connect "127.0.0.1:$port" --token "$viewer" --name bare \
    --frames 1 --craters 0 --settle 0.2 --report "$out/bare.json" > /dev/null
joined=$(memory)
stop_server
terrain=$(grep -o '"terrain_mib": [0-9.]*' "$out/battle_bench.json")
echo "{\"shots\": $shots, $terrain, \"idle\": {$idle}, \"after_battle\": {$battle}," \
    "\"after_two_joins\": {$joined}}"
