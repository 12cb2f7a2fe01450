#!/usr/bin/env bash
# The game client as a user gets it: `cmake --install` of this build into a fresh prefix, then
# the C++ example (examples/cpp, find_package(terrain) and terrain::client) configured and built
# against that prefix alone, the C example built as C99 with pkg-config, both again against the
# static archive (terrain::client_static, pkg-config's terrain_client_static), the headers
# compiled on their own as C99 and C++17 with no include path but the prefix's, and the four
# programs run against a live terrain-server: each must end holding the server's world.
#
#   consumer_check.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1
src=$2
work=$(mktemp -d)
server_pid=""
cleanup() {
    [ -z "$server_pid" ] || kill "$server_pid" 2> /dev/null || true
    [ -z "$server_pid" ] || wait "$server_pid" 2> /dev/null || true
    rm -rf "$work"
}
trap cleanup EXIT
fail() {
    echo "consumer_check: FAILED: $*" >&2
    exit 1
}
prefix=$work/prefix
cmake --install "$build" --prefix "$prefix" > "$work/install.log" || fail "cmake --install"

echo "== the C++ example against the installed package"
generator=()
command -v ninja > /dev/null && generator=(-G Ninja)
cmake -S "$src/examples/cpp" -B "$work/cpp" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$prefix" > "$work/cpp-configure.log" 2>&1 \
    || { cat "$work/cpp-configure.log"; fail "configuring examples/cpp"; }
cmake --build "$work/cpp" > "$work/cpp-build.log" 2>&1 \
    || { cat "$work/cpp-build.log"; fail "building examples/cpp"; }

echo "== the C example as C99, with pkg-config"
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
# shellcheck disable=SC2046 # pkg-config's words are separate arguments
cc -std=c99 -Wall -Wextra -pedantic -Werror $(pkg-config --cflags terrain_client) \
    "$src/examples/c/crater.c" -o "$work/crater" $(pkg-config --libs terrain_client) \
    -Wl,-rpath,"$prefix/lib" || fail "building examples/c/crater.c with pkg-config"

echo "== both again, static: terrain::client_static and pkg-config's terrain_client_static"
mkdir -p "$work/cpp_static_src"
cp "$src/examples/cpp/main.cpp" "$work/cpp_static_src/"
sed 's/terrain::client)/terrain::client_static)/' "$src/examples/cpp/CMakeLists.txt" \
    > "$work/cpp_static_src/CMakeLists.txt"
grep -q 'terrain::client_static' "$work/cpp_static_src/CMakeLists.txt" || fail "the static CMake"
cmake -S "$work/cpp_static_src" -B "$work/cpp_static" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$prefix" > "$work/cpp-static.log" 2>&1 \
    && cmake --build "$work/cpp_static" >> "$work/cpp-static.log" 2>&1 \
    || { cat "$work/cpp-static.log"; fail "examples/cpp against terrain::client_static"; }
# shellcheck disable=SC2046 # pkg-config's words are separate arguments
cc -std=c99 -Wall -Wextra -pedantic -Werror $(pkg-config --cflags terrain_client_static) \
    "$src/examples/c/crater.c" -o "$work/crater_static" $(pkg-config --libs terrain_client_static) \
    || fail "building examples/c/crater.c with pkg-config's terrain_client_static"
for program in "$work/cpp_static/game_example" "$work/crater_static"; do
    ! readelf -d "$program" | grep -q 'libterrain_client' \
        || fail "$program needs libterrain_client.so: it was to be static"
done

echo "== the headers alone: C99 and C++17, the prefix's include folder only"
printf '#include <terrain_client.h>\nint main(void) { return terrain_abi_version() == TERRAIN_CLIENT_ABI_VERSION ? 0 : 1; }\n' \
    > "$work/c99.c"
cc -std=c99 -Wall -Wextra -pedantic -Werror -I"$prefix/include" -c "$work/c99.c" -o "$work/c99.o" \
    || fail "terrain_client.h as C99"
printf '#include <terrain_replica.h>\nint main(void) { terrain_replica* r = 0; return terrain_replica_create(&r) == TERRAIN_OK ? 0 : 1; }\n' \
    > "$work/replica_c99.c"
cc -std=c99 -Wall -Wextra -pedantic -Werror -I"$prefix/include" -c "$work/replica_c99.c" \
    -o "$work/replica_c99.o" || fail "terrain_replica.h as C99"
printf '#include <terrain/game/replica.h>\nint main() { terrain::game::Replica r; return r.state().loaded; }\n' \
    > "$work/replica_cxx17.cpp"
c++ -std=c++17 -Wall -Wextra -pedantic -Werror -I"$prefix/include" -c "$work/replica_cxx17.cpp" \
    -o "$work/replica_cxx17.o" || fail "terrain/game/replica.h as C++17"
printf '#include <terrain/game/client.h>\nint main() { return terrain::game::Client::indicesPerPage() > 0 ? 0 : 1; }\n' \
    > "$work/cxx17.cpp"
c++ -std=c++17 -Wall -Wextra -pedantic -Werror -I"$prefix/include" -c "$work/cxx17.cpp" \
    -o "$work/cxx17.o" || fail "terrain/game/client.h as C++17"

echo "== both against a live server"
secret=consumer-check-secret-0123456789
"$prefix/bin/terrain-server" --token-secret "$secret" serve --bind 127.0.0.1 --port 0 \
    --port-file "$work/port" --no-journal --size 257 > "$work/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 1 300); do
    [ -s "$work/port" ] && break
    sleep 0.05
done
[ -s "$work/port" ] || { cat "$work/server.log"; fail "the server did not start"; }
port=$(cat "$work/port")
token=$("$prefix/bin/terrain-server" --token-secret "$secret" token --player 61 --role deformer)
world() { "$prefix/bin/terrain-server" health --connect "127.0.0.1:$port" | grep -o 'seq [0-9]*, hash [0-9a-f]*' | tr -d ','; }

"$work/cpp/game_example" 127.0.0.1 "$port" "$token" > "$work/cpp.out" 2>&1 \
    || { cat "$work/cpp.out"; fail "examples/cpp"; }
cat "$work/cpp.out"
grep -q "^$(world) " "$work/cpp.out" || fail "examples/cpp does not hold the server's world ($(world))"

"$work/crater" 127.0.0.1 "$port" "$token" > "$work/c.out" 2>&1 || { cat "$work/c.out"; fail "examples/c"; }
cat "$work/c.out"
grep -q "^$(world) " "$work/c.out" || fail "examples/c does not hold the server's world ($(world))"
for program in "$work/cpp_static/game_example" "$work/crater_static"; do
    "$program" 127.0.0.1 "$port" "$token" > "$work/static.out" 2>&1 \
        || { cat "$work/static.out"; fail "$program"; }
    cat "$work/static.out"
    grep -q "^$(world) " "$work/static.out" || fail "$program does not hold the server's world"
done
echo "consumer_check: the installed package builds both examples, shared and static; all four hold the server's world"
