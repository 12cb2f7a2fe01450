#!/usr/bin/env bash
# The renderer's checks on a machine with a GPU (NVIDIA, through EGL), prepared for a session that
# has one (device time is scarce: one run of this, about 6 minutes). Here first:
#   cmake --build build/release
#   bash ../shared/gpu/bundle.sh build/release tests/render_tests   # -> .gpu/
# then on the GPU machine, from the repo root with .gpu/ carried along:
#   bash tests/gpu/render_check.sh
# 1. the render tests that take a backend (the battle with a GPU's frame timing, buffers read
#    back, pictures against fresh buffers; validation; GPU timer; bytes per crater) through EGL;
# 2. ../shared/gpu/check.sh's scenes through the bot with --gl-debug: a shooter (10 craters,
#    300 frames, seed 11, also --validate-buffers), a late joiner on the same path, and the
#    2,000-frame battle (seed 3); each line: holes in the last frame (the bot counts them),
#    driver errors, buffer mismatches, and render / sync / GPU times.
# Frames and reports go to $OUT.
set -u
top=$(cd "$(dirname "$0")/../.." && pwd)
g=$top/.gpu
[ -x "$g/run" ] || { echo "render_check: no .gpu/ (run ../shared/gpu/bundle.sh first)" >&2; exit 2; }
o=${OUT:-$(mktemp -d)}; w=$(mktemp -d); mkdir -p "$o"
command -v nvidia-smi > /dev/null && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader

echo "== render tests through EGL"
TERRAIN_TEST_GL=egl timeout 400 "$g/run" render_tests \
    --gtest_filter='Paths/RenderBattle.*:RenderValidation.*:GpuTimer.*:RenderBattleUploads.*' 2>&1 |
    grep -E '^\[ +(OK|FAILED|PASSED) |Failure|craters|KB sent|GL (high|medium)' | head -60

export TERRAIN_TOKEN_SECRET="gpu-check-secret-0123456789abcdef"
serve() {
    rm -f "$w/port"
    "$g/run" terrain-server serve --no-journal --deform-rate 100000 --port 0 --port-file "$w/port" \
        > "$w/server.log" 2>&1 &
    srv=$!
    for _ in $(seq 1 300); do [ -s "$w/port" ] && break; sleep 0.1; done
    port=$(cat "$w/port")
}
bot() { # NAME ROLE CRATERS FRAMES SEED [ARGS...]
    local n=$1 role=$2 c=$3 f=$4 s=$5
    shift 5
    timeout 300 "$g/run" terrain-bot --connect "127.0.0.1:$port" --name "$n" --seed "$s" \
        --frames "$f" --craters "$c" --token "$("$g/run" terrain-server token --player 1 --role "$role")" \
        --tau 1 --width 1280 --height 720 --render --gl egl --frame-ms 0 --gl-debug \
        --png-dir "$w/$n" --report "$w/$n.json" "$@" > "$w/$n.out" 2>&1
    echo "$n: rc=$? $(python3 - "$w/$n.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
u = r['upload']
print('holes', r['after_holes'], '| gl errors', r['gl_errors'], 'messages', r['gl_messages'],
      '| mismatches', r['buffer_mismatches'], '| path', u['path'], '| renderer', r['renderer'],
      '| frame', r['frame_ms'], '| render', r['render_ms'], '| sync', r['sync_ms'],
      '| draw', r['draw_ms'], '| present', r['present_ms'], '| gpu', r['gpu_ms'],
      '| copies/frame', u['copies_per_frame'], '| bytes/frame', u['per_frame'],
      '| error bound', r['error_bound_pixels'], '| error', r['error'])
PY
)"
    grep -m 5 '^GL ' "$w/$n.out"
    cp "$w/$n/after.png" "$o/$n.png" 2> /dev/null
    cp "$w/$n.json" "$o/" 2> /dev/null
}
echo "== the GPU check's scenes"
serve
bot shooter deformer 10 300 11 --validate-buffers
bot late viewer 0 300 11
kill $srv; wait $srv 2> /dev/null
serve
bot battle deformer 2000 2000 3 --settle 0.5
kill $srv; wait $srv 2> /dev/null
rm -rf "$w"
