#!/usr/bin/env bash
# Speed against accuracy, regenerated: runs lod_bench (every LOD method on the default map and
# every DEM, six flights, tau 0.25-8 px, with and without a binding triangle cap; geomorphing is
# one of the methods) and draws its
# charts with gnuplot into docs/lod/ (the ones BENCHMARKS.md shows; the CSV and JSON stay in
# out/lod/). Build first: cmake --preset release && cmake --build --preset release.
#
#   bash tests/bench/lod_report.sh            # the full report (about 60 minutes on 2 cores;
#                                             # markdown tables in out/lod/tables.md)
#   bash tests/bench/lod_report.sh --smoke D  # a tiny map and few frames into D, then checks
#                                             # that every file is there and not empty
#   bash tests/bench/lod_report.sh --charts   # the charts and tables again from out/lod/*/
set -euo pipefail
cd "$(dirname "$0")/../.."

bench=${LOD_BENCH:-build/release/tests/lod_bench}
smoke=""
charts_only=""
out=out/lod
charts=docs/lod
if [ "${1:-}" = "--smoke" ]; then
    smoke=1
    out=${2:?--smoke needs an output directory}
    charts=$out
elif [ "${1:-}" = "--charts" ]; then
    charts_only=1
fi
[ -x "$bench" ] || { echo "lod_report: $bench is not built (cmake --build --preset release)"; exit 2; }
command -v gnuplot > /dev/null || { echo "lod_report: gnuplot is missing (apt-get install gnuplot-nox)"; exit 2; }
mkdir -p "$out" "$charts"

if [ -n "$smoke" ]; then
    "$bench" --maps small --frames 24 --measures 3 --pre-shots 40 --width 320 --height 180 \
        --taus 1,4 --caps 0,3000 --out-dir "$out" > "$out/lod_bench.log"
    scenarios="small:cruise small:low small:whip small:battle"
    series="small:battle small:teleport"
    cap_scenario=small:cruise
    cap=3000
else
    # three passes, one table: every flight on the default map and the SRTM tile at six taus;
    # the other DEMs cruising and low; and a triangle cap that binds
    common=(--frames 180 --measures 6 --pre-shots 1000 --save-frames)
    [ -n "$charts_only" ] || "$bench" --maps default,srtm_n44w072 --taus 0.25,0.5,1,2,4,8 --caps 0 \
        "${common[@]}" --out-dir "$out/main" | tee "$out/lod_bench.log"
    others=$(ls ../shared/data/dem 2> /dev/null | grep -v -e README -e srtm_n44w072 |
        tr '\n' ',' || true)
    if [ -n "$others" ] && [ -z "$charts_only" ]; then
        "$bench" --maps "${others%,}" --flights cruise,low --taus 0.5,1,2,4 --caps 0 \
            "${common[@]}" --out-dir "$out/dems" | tee -a "$out/lod_bench.log"
    fi
    [ -n "$charts_only" ] || "$bench" --maps default,srtm_n44w072 --flights cruise,battle \
        --methods split_merge,split_only,chunked --taus 0.25,0.5,1 --caps 60000 \
        "${common[@]}" --out-dir "$out/cap" | tee -a "$out/lod_bench.log"
    for f in runs.csv frames.csv; do
        head -n 1 "$out/main/$f" > "$out/$f"
        for pass in main dems cap; do
            if [ -f "$out/$pass/$f" ]; then tail -n +2 "$out/$pass/$f" >> "$out/$f"; fi
        done
    done
    scenarios="srtm_n44w072:cruise srtm_n44w072:low srtm_n44w072:whip default:battle"
    series="default:battle srtm_n44w072:teleport"
    cap_scenario=srtm_n44w072:cruise
    cap=60000
fi

methods="split_merge split_only full_mesh chunked split_merge_morph"
series_dir=$out/series
rm -rf "$series_dir"
mkdir -p "$series_dir"
# one file per scenario and method (runs without a cap), so gnuplot draws each as one line
for s in $scenarios $series; do
    map=${s%%:*}
    flight=${s##*:}
    for m in $methods; do
        awk -F, -v map="$map" -v flight="$flight" -v m="$m" \
            '$1 == map && $2 == flight && $3 == m && $5 == 0' "$out/runs.csv" \
            > "$series_dir/runs_${map}_${flight}_$m.csv"
        awk -F, -v map="$map" -v flight="$flight" -v m="$m" \
            '$1 == map && $2 == flight && $3 == m && $4 == 1 && $5 == 0' "$out/frames.csv" \
            > "$series_dir/frames_${map}_${flight}_$m.csv"
    done
done

cap_map=${cap_scenario%%:*}
cap_flight=${cap_scenario##*:}
for m in split_merge split_only chunked; do
    for c in 0 "$cap"; do
        awk -F, -v map="$cap_map" -v flight="$cap_flight" -v m="$m" -v c="$c" \
            '$1 == map && $2 == flight && $3 == m && $5 == c' "$out/runs.csv" \
            > "$series_dir/cap_${m}_$c.csv"
    done
done

# one facet per scenario, one curve per method
facets() { # $1: x column, $2: y column, $3: title, $4: x label, $5: y label, $6: extra settings
    echo "set multiplot layout 2,2 title '$3'"
    for s in $scenarios; do
        local map=${s%%:*} flight=${s##*:} plots=""
        echo "set title '$map, $flight'; set xlabel '$4'; set ylabel '$5'; $6"
        for m in $methods; do
            plots+="'$series_dir/runs_${map}_${flight}_$m.csv' using (floor0(\$$1)):(floor0(\$$2)) title '$m', "
        done
        echo "plot ${plots%, }"
    done
    echo "unset multiplot"
}

{
    echo "set datafile separator ','"
    echo "set terminal pngcairo size 1400,1000 font 'sans,10' noenhanced"
    echo "set key top right; set grid; set style data linespoints"
    # log axes: an exact zero (the full mesh's error) is drawn at 0.001
    echo "lo = 0.001; floor0(v) = v > lo ? v : lo"
    echo "set output '$charts/cpu_vs_error.png'"
    # CPU per frame (p50) against measured screen error (p99): the Pareto view
    facets 15 6 "CPU per frame against measured screen error (p99 of triangles), one point per tau (0 drawn at 0.001)" \
        "screen error p99 (px)" "CPU per frame, median (ms)" "set logscale y; set logscale x"
    echo "set output '$charts/triangles_vs_tau.png'"
    facets 4 9 "Triangles drawn (median) against tau" "tau (px)" "triangles" \
        "set logscale x; set logscale y"
    echo "set output '$charts/error_vs_triangles.png'"
    facets 9 14 "Measured screen error (max) against triangles drawn (0 drawn at 0.001)" \
        "triangles (median)" "screen error max (px)" "set logscale x; set logscale y"
    echo "set output '$charts/image_vs_triangles.png'"
    facets 9 24 "Image error against triangles: share of pixels off the full-resolution render by more than 16/255 (0 drawn at 1e-5)" \
        "triangles (median)" "share of pixels" "set logscale x; set logscale y; lo = 1e-5"
    echo "set output '$charts/popping_vs_tau.png'"
    facets 4 28 "Popping against tau: share of pixels whose change from the last frame differs from the full-resolution sequence (0 drawn at 1e-5)" \
        "tau (px)" "share of pixels" "set logscale x; set logscale y; lo = 1e-5"
    echo "set output '$charts/lod_change_vs_tau.png'"
    facets 4 30 "LOD change against tau: share of pixels that differ between the meshes of the last frame and this one, both drawn from this camera (0 drawn at 1e-7)" \
        "tau (px)" "share of pixels" "set logscale x; set logscale y; lo = 1e-7"
    echo "set output '$charts/upload_vs_tau.png'; lo = 0.001"
    facets 4 11 "Bytes uploaded per frame (mean) against tau" "tau (px)" "bytes per frame" \
        "set logscale x; set logscale y"
    # the cap: triangles and the error it costs, with and without it
    echo "set output '$charts/cap.png'; lo = 0.001"
    echo "set multiplot layout 1,2 title '$cap_map, $cap_flight: a cap of $cap triangles against none'"
    for pair in "9:triangles (median)" "13:error bound, largest (px)"; do
        col=${pair%%:*}
        label=${pair#*:}
        plots=""
        for m in split_merge split_only chunked; do
            for c in 0 "$cap"; do
                plots+="'$series_dir/cap_${m}_$c.csv' using 4:(floor0(\$$col)) title '$m, cap $c', "
            done
        done
        echo "set title '$label'; set xlabel 'tau (px)'; set ylabel '$label'; set logscale x; set logscale y"
        echo "plot ${plots%, }"
    done
    echo "unset multiplot"
    # per-frame CPU of one flight at tau 1, events marked
    echo "set output '$charts/frame_series.png'"
    echo "set multiplot layout 2,1 title 'CPU per frame at tau = 1 px (teleports marked in grey; in the battle a shot lands every frame)'"
    echo "unset logscale x; set logscale y"
    for s in $series; do
        map=${s%%:*}
        flight=${s##*:}
        plots=""
        for m in $methods; do
            plots+="'$series_dir/frames_${map}_${flight}_$m.csv' using 6:(floor0(\$7)) with lines title '$m', "
        done
        plots+="'$series_dir/frames_${map}_${flight}_split_merge.csv' using (strcol(14) eq 'teleport' ? \$6 : NaN):(1e4) with impulses lc rgb '#aaaaaa' title 'teleport'"
        echo "set title '$map, $flight'; set xlabel 'frame'; set ylabel 'ms (0 drawn at 0.001)'"
        echo "plot $plots"
    done
    echo "unset multiplot"
} > "$out/charts.gp"
gnuplot "$out/charts.gp"
python3 tests/bench/lod_tables.py "$out/runs.csv" 1 > "$out/tables.md"

if [ -n "$smoke" ]; then
    for f in runs.csv frames.csv runs.json tables.md; do
        [ -s "$out/$f" ] || { echo "lod_report: $out/$f is missing or empty"; exit 1; }
    done
    for f in cpu_vs_error triangles_vs_tau error_vs_triangles image_vs_triangles popping_vs_tau \
        lod_change_vs_tau upload_vs_tau frame_series cap; do
        [ "$(stat -c %s "$charts/$f.png")" -gt 10000 ] || {
            echo "lod_report: $charts/$f.png is missing or blank"
            exit 1
        }
    done
    # every method and flight ran, and each was measured
    for m in $methods; do
        grep -q ",$m," "$out/runs.csv" || { echo "lod_report: no run of $m"; exit 1; }
    done
    echo "lod_report: smoke run complete in $out"
else
    # the battle's frames at tau 1 as each method draws it, and the reference
    mkdir -p "$charts/frames"
    for f in reference split_merge chunked split_merge_morph; do
        src=$out/main/frames/default_battle_$f.png
        if [ -f "$src" ]; then cp "$src" "$charts/frames/"; fi
    done
    echo "lod_report: charts in $charts/, data in $out/"
fi
