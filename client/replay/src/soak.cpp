#include <terrain/io/genesis.h>
#include <terrain/replay/soak.h>

#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <optional>

namespace terrain::replay {

bool SoakResult::agreed() const {
    const std::uint64_t accepted = live.last_seq - live.base_seq;
    return !live.timed_out && live.ops_fed == counts.total() && live.ops_accepted == accepted &&
           offline.last_seq == live.last_seq && offline.records_checked == accepted &&
           disagreements == 0 && seqs_compared == accepted * live.clients.size() &&
           !live.first_divergence;
}

Result<SoakResult> runSoak(const SoakOptions& options) {
    if (options.ops == 0)
        return makeError(ErrorCode::kOutOfRange, "a soak needs at least one op");
    if (options.directory.empty())
        return makeError(ErrorCode::kOutOfRange, "a soak needs a directory for its journal");
    std::error_code ec;
    if (std::filesystem::exists(options.directory, ec) &&
        !std::filesystem::is_empty(options.directory, ec))
        return makeError(
            ErrorCode::kIo, options.directory.string() + " is not empty (the soak's journal "
                                                         "goes there)");
    io::GenesisOptions map; // the procedural map, as a new server makes it
    map.seed = options.seed;
    map.size = options.map_size;
    auto world = io::makeGenesis(map);
    if (!world)
        return world.error();
    const Terrain* genesis = &world->terrain;

    SoakResult result;
    {
        // every snapshot kept: the offline replay starts from the genesis
        journal::JournalOptions jo;
        jo.durability = journal::Durability::kWrite;
        jo.keep_snapshots = std::size_t{1} << 20;
        auto journal = journal::Journal::open(options.directory, jo);
        if (!journal)
            return journal.error();
        if (Status s = journal->initialize(*genesis, 0); !s)
            return s.error();
        SoakOps source(options.seed, genesis->spec(), options.mix);
        std::uint64_t made = 0;
        LiveRunInput input;
        input.base = genesis;
        input.base_seq = 0;
        input.journal = &*journal;
        input.next = [&](const client::Replica& feeder) -> std::optional<FeedRequest> {
            if (made == options.ops)
                return std::nullopt;
            ++made;
            return source.next(feeder.terrain());
        };
        LiveRunOptions live = options.live;
        live.keep_hashes = true;
        auto run = runLive(input, live);
        if (!run)
            return run.error();
        result.live = std::move(*run);
        result.counts = source.counts();
    } // the server has drained; the journal is closed

    const auto offline_start = std::chrono::steady_clock::now();
    auto history = journal::readJournal(options.directory);
    result.offline_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - offline_start).count();
    if (!history)
        return history.error();
    result.offline = history->report;
    for (ClientTally& c : result.live.clients) {
        for (std::size_t i = 0; i < history->records.size(); ++i) {
            ++result.seqs_compared;
            const std::uint64_t seen = i < c.hashes.size() ? c.hashes[i] : 0;
            if (seen == history->records[i].world_hash)
                continue;
            if (++result.disagreements == 1) {
                char buf[200];
                std::snprintf(
                    buf, sizeof buf, "%s at seq %" PRIu64 ": %s, the journal %016" PRIx64,
                    c.name.c_str(), history->records[i].seq,
                    seen == 0 ? "never saw it" : ("hash " + std::to_string(seen)).c_str(),
                    history->records[i].world_hash);
                result.first_disagreement = buf;
            }
        }
        c.hashes.clear(); // 8 bytes a seq: not needed past here
        c.hashes.shrink_to_fit();
    }
    return result;
}

} // namespace terrain::replay
