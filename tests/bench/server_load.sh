#!/usr/bin/env bash
# Load with clients in separate processes: a terrain-server with the fsync journal, P processes
# of light viewers (load_viewers: V each, decoding every op), and one deformer process
# (battle_feed) sending battle_bench's battle ops, windowed or paced. Prints the feed's line and
# the latency from each request's send to its op's receipt by every viewer.
# Usage: bash tests/bench/server_load.sh [feed options...]
#   env: SHOTS (4000), PROCS (4), VIEWERS (16 per process), SERVER_FLAGS (e.g. --batch-broadcasts),
#        SERVER_BIN (another terrain-server binary, for before/after runs),
#        JOIN_EVERY (seconds: a fresh viewer process joins by snapshot that often during the feed)
# Examples: bash tests/bench/server_load.sh --rate 600
#           bash tests/bench/server_load.sh --window 256
#           PROCS=8 VIEWERS=32 bash tests/bench/server_load.sh --rate 100
set -euo pipefail
cd "$(dirname "$0")/../.."
shots=${SHOTS:-4000}
procs=${PROCS:-4}
viewers=${VIEWERS:-16}
bin=build/release
# shellcheck source=tests/bench/bench_server.sh
source tests/bench/bench_server.sh
bench_folder out/bench/server_load
"$bin/tests/battle_bench" --shots "$shots" --ops "$out/ops.txt" > /dev/null
# shellcheck disable=SC2086
start_server "$out/server.log" "${SERVER_BIN:-$bin/server/terrain-server}" --data-dir "$out/data" \
    --deform-rate 100000 --max-sessions 4096 --max-pending 4096 \
    --max-pending-per-address 4096 ${SERVER_FLAGS:-}
trap 'kill $server 2> /dev/null || true' EXIT
viewer_token=$("$bin/server/terrain-server" token --player 2 --role viewer)
pids=()
for p in $(seq 1 "$procs"); do
    "$bin/tests/load_viewers" run --port "$port" --token "$viewer_token" --viewers "$viewers" \
        --until "$shots" --out "$out/receipts$p.txt" > "$out/viewers$p.log" 2>&1 &
    pids+=($!)
done
sleep 2 # every viewer joined at seq 0
joiner=""
if [ -n "${JOIN_EVERY:-}" ]; then
    (
        while :; do
            sleep "$JOIN_EVERY"
            start=$(date +%s%N)
            "$bin/tests/load_viewers" run --port "$port" --token "$viewer_token" --viewers 1 \
                --until 1 --out /dev/null > /dev/null 2>&1 || true
            echo "join $((($(date +%s%N) - start) / 1000000)) ms" >> "$out/joins.txt"
        done
    ) &
    joiner=$!
fi
"$bin/tests/battle_feed" --port "$port" --ops "$out/ops.txt" --sends "$out/sends.txt" "$@" \
    --token "$("$bin/server/terrain-server" token --player 1 --role deformer)"
if [ -n "$joiner" ]; then
    kill "$joiner" 2> /dev/null || true
    echo "$(wc -l < "$out/joins.txt") joins during the feed:" \
        "$(sort -n -k2 "$out/joins.txt" | awk '{ a[NR] = $2 } END { print "p50", a[int((NR + 1) / 2)], "ms, max", a[NR], "ms" }')"
fi
status=0
for p in "${pids[@]}"; do wait "$p" || status=1; done
cat "$out"/viewers*.log
receipts=()
for p in $(seq 1 "$procs"); do receipts+=("$out/receipts$p.txt"); done
"$bin/tests/load_viewers" merge --sends "$out/sends.txt" --receipts "${receipts[@]}" || status=1
echo "($procs processes x $viewers light viewers, server flags: ${SERVER_FLAGS:-none})"
stop_server
exit $status
