#!/usr/bin/env bash
# The frame budget against llvmpipe: one server, then one rendering bot per --frame-ms setting
# (same seed, flight and craters), each run's frame times, cap and error bound printed from its
# report. Usage: bash tests/bench/frame_budget.sh [tau] [frame-ms settings...]
# (defaults: tau 1, settings 0 and 50). Needs the release build (build/release).
set -euo pipefail
cd "$(dirname "$0")/../.."
tau=${1:-1}
shift || true
settings=("$@")
[ ${#settings[@]} -gt 0 ] || settings=(0 50)
bin=build/release
# shellcheck source=tests/bench/bench_server.sh
source tests/bench/bench_server.sh
bench_folder out/bench/frame_budget
start_server "$out/server.log" "$bin/server/terrain-server" --no-journal
trap 'kill $server 2> /dev/null || true' EXIT
endpoint="127.0.0.1:$port"
for ms in "${settings[@]}"; do
    token=$("$bin/server/terrain-server" token --player 1 --role deformer)
    "$bin/client/bot/terrain-bot" --connect "$endpoint" --token "$token" --name "ms$ms" \
        --seed 11 --frames 300 --craters 10 --tau "$tau" --width 1280 --height 720 --render \
        --frame-ms "$ms" --report "$out/ms$ms.json" > "$out/ms$ms.log" 2>&1
    python3 - "$out/ms$ms.json" "$ms" "$tau" << 'PY'
import json, sys
r = json.load(open(sys.argv[1]))
f = lambda k: "%.1f / %.1f / %.0f" % (r[k]["median"], r[k]["p95"], r[k]["max"])
print("tau %s --frame-ms %s: frame ms %s, render median %.1f, triangles median %.0f, cap median %.0f, "
      "error bound median / p95 %.2f / %.2f px" % (sys.argv[3], sys.argv[2], f("frame_ms"),
      r["render_ms"]["median"], r["triangles"]["median"], r["triangle_cap"]["median"],
      r["error_bound_pixels"]["median"], r["error_bound_pixels"]["p95"]))
PY
done
