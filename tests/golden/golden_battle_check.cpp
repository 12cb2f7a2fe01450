// The golden battle without a test framework, so that any compiler and any CPU can run it: the
// canonical ops of tests/data/golden_battle_ops.txt (2,000 shots of the battle generator on a
// 257 x 257 procedural map) applied in order, and the world hash compared with the golden one.
// CI runs it from the clang build; .ci/cross runs it under qemu for aarch64 and s390x. The
// battle is applied serially and again with Terrain::apply's thread pool at 4 threads, whose
// world hash must equal the serial one after every op.
//   golden_battle_check <tests/data>   exit 0: the golden hash; 1: another; 2: unreadable data

#include <terrain/op_script.h>
#include <terrain/procedural_map.h>
#include <terrain/task_runner.h>
#include <terrain/terrain.h>

#include <cinttypes>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

namespace {

std::string readText(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: golden_battle_check <tests/data directory>\n");
        return 2;
    }
    const std::string dir = argv[1];
    // golden_battle.txt: "map <size> <seed>", "ops <file>", "map_hash", "final", "patches"
    std::istringstream golden(readText(dir + "/golden_battle.txt"));
    std::int32_t size = 0;
    std::uint64_t seed = 0;
    std::string ops_file;
    std::uint64_t map_hash = 0;
    std::uint64_t final_hash = 0;
    std::size_t patches = 0;
    for (std::string key; golden >> key;) {
        if (key[0] == '#')
            golden.ignore(1 << 20, '\n');
        else if (key == "map")
            golden >> size >> seed;
        else if (key == "ops")
            golden >> ops_file;
        else if (key == "map_hash")
            golden >> std::hex >> map_hash >> std::dec;
        else if (key == "final")
            golden >> std::hex >> final_hash >> std::dec;
        else if (key == "patches")
            golden >> patches;
    }
    if (size == 0 || ops_file.empty()) {
        std::fprintf(
            stderr, "golden_battle_check: %s/golden_battle.txt is missing or incomplete\n",
            dir.c_str());
        return 2;
    }
    auto ops = terrain::parseCanonicalOps(readText(dir + "/" + ops_file));
    if (!ops || ops->empty()) {
        std::fprintf(
            stderr, "golden_battle_check: %s: %s\n", ops_file.c_str(),
            ops ? "no ops" : ops.error().message.c_str());
        return 2;
    }
    terrain::ProceduralMapOptions o;
    o.seed = seed;
    o.width = o.height = size;
    auto t = terrain::makeProceduralMap(o);
    if (!t) {
        std::fprintf(stderr, "golden_battle_check: map: %s\n", t.error().message.c_str());
        return 2;
    }
    const std::uint64_t genesis = t->worldHash();
    terrain::Terrain pooled = *t;
    terrain::ThreadPool pool(4);
    std::size_t threads_differ = 0;
    for (const terrain::DeformOp& op : *ops) {
        if (auto e = t->apply(op); !e) {
            std::fprintf(
                stderr, "golden_battle_check: an op was refused: %s\n", e.error().message.c_str());
            return 1;
        }
        if (auto e = pooled.apply(op, &pool); !e || pooled.worldHash() != t->worldHash())
            ++threads_differ;
    }
    if (threads_differ > 0)
        std::printf("%zu ops gave another world hash at 4 threads\n", threads_differ);
    const bool ok = genesis == map_hash && t->worldHash() == final_hash &&
                    t->patchCount() == patches && threads_differ == 0;
    std::printf(
        "golden battle: %zu ops on %d x %d (seed %" PRIu64 "): map %016" PRIx64
        ", final %016" PRIx64 ", %zu patches: %s\n",
        ops->size(), size, size, seed, genesis, t->worldHash(), t->patchCount(),
        ok ? "the golden hash" : "NOT the golden hash");
    if (!ok)
        std::printf(
            "expected map %016" PRIx64 ", final %016" PRIx64 ", %zu patches\n", map_hash,
            final_hash, patches);
    return ok ? 0 : 1;
}
