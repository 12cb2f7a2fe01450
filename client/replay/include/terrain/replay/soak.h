#pragma once

// A soak: fuzzed ops (soak_ops.h) through a live server that keeps a journal, to N clients
// (live_run.h), then the journal replayed offline from its genesis: every record's hash is
// recomputed, and every client's hash at every seq must equal the journal's at that seq.
// Refusals are expected (a share of the ops is invalid on purpose) and counted by reason.

#include <terrain/journal/journal.h>
#include <terrain/replay/live_run.h>
#include <terrain/replay/soak_ops.h>
#include <terrain/result.h>

#include <cstdint>
#include <filesystem>
#include <string>

namespace terrain::replay {

struct SoakOptions {
    std::uint64_t ops = 100000;
    std::uint64_t seed = 1;
    std::int32_t map_size = 513;     ///< vertices per side of the procedural genesis
    std::filesystem::path directory; ///< the server's journal; must not exist or be empty
    SoakMix mix;
    LiveRunOptions live; ///< clients, window, time limit (keep_hashes is forced on)
};

struct SoakResult {
    LiveRunResult live;
    SoakCounts counts;
    journal::VerifyReport offline; ///< the journal, replayed from its genesis
    double offline_seconds = 0.0;
    std::uint64_t seqs_compared = 0; ///< client-seq pairs compared with the journal
    std::uint64_t disagreements = 0; ///< of those, pairs that differ (or were never seen)
    std::string first_disagreement;  ///< "client-3 at seq 812: ..." when any

    /// Every op answered, the journal holds every accepted op, and every client's hash at
    /// every seq equals the journal's.
    bool agreed() const;
};

/// Errors: kOutOfRange (bad options), kIo (the directory), the journal's and runLive()'s.
Result<SoakResult> runSoak(const SoakOptions& options);

} // namespace terrain::replay
