#pragma once

// A recorded match replayed through a live server: the journal's base state becomes a real
// Server (this build, on loopback, in its own thread), one client feeds it the journal's ops in
// order, and N clients (the feeder among them) apply what the server broadcasts. At every seq,
// every client's world hash is checked against the hash the journal recorded. The feeder waits
// for the slowest client, so no client is ever pushed into a snapshot resync that would skip
// seqs unchecked. The first divergence keeps a copy of the diverged state for a desync report
// (desync_report.h). Run time is bounded.

#include <terrain/client/replica.h>
#include <terrain/deform_op.h>
#include <terrain/journal/journal.h>
#include <terrain/result.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace terrain::replay {

struct LiveReplayOptions {
    std::size_t clients = 4;           ///< clients checked at every seq, the feeder included
    double time_limit_seconds = 600.0; ///< the run stops here, finished or not
    std::size_t window = 64;           ///< ops in flight ahead of the slowest client
    bool batch_broadcasts = false;     ///< the server's --batch-broadcasts
    /// Called before each client's check at each seq (tests corrupt a replica here).
    std::function<void(std::size_t client, std::uint64_t seq, client::Replica& replica)>
        before_check;
};

/// What one client saw.
struct ClientTally {
    std::string name;
    std::uint64_t checked = 0;    ///< seqs whose hash this client compared with the journal's
    std::uint64_t mismatches = 0; ///< of those, seqs where it differed
    std::uint64_t repairs = 0;    ///< tile repairs that restored the server's hash
    std::uint64_t snapshots = 0;  ///< whole-state loads (the join, and any resync)
    std::uint64_t final_seq = 0;
    std::uint64_t final_hash = 0;
    std::string last_disconnect; ///< empty unless the link dropped
};

/// The first seq where a client's world differed from the journal's.
struct Divergence {
    std::uint64_t seq = 0;
    DeformOp op;
    std::size_t client = 0;
    /// True when the client had verified this seq's hash equal to the live server's and still
    /// held that state: the server itself (this build) differs from the journal. False when the
    /// client differs from the server it follows, or (batched broadcasts) had no server hash
    /// for this op.
    bool server_differs = false;
    std::uint64_t journal_hash = 0;
    std::uint64_t observed_hash = 0;
    std::optional<Terrain> observed; ///< the client's state at seq, copied before any repair
};

struct LiveReplayResult {
    std::uint64_t base_seq = 0;
    std::uint64_t last_seq = 0;
    std::uint64_t ops_fed = 0;     ///< ops the feeder sent
    std::uint64_t ops_refused = 0; ///< ops the live server refused or numbered differently
    std::string first_refusal;     ///< "seq N: reason" of the first
    double seconds = 0.0;
    bool timed_out = false;
    std::vector<ClientTally> clients;
    std::optional<Divergence> first_divergence;

    /// Every client checked every seq and agreed with the journal, and nothing was refused.
    bool agreed() const;
};

/// Replays `history` through a live server to `options.clients` clients.
/// Errors: kOutOfRange for no clients or no window; the server's kIo when it cannot listen.
Result<LiveReplayResult>
runLiveReplay(const journal::JournalHistory& history, const LiveReplayOptions& options);

/// The journal's state after record `seq` (history.base_seq <= seq <= the last record's),
/// replayed offline: the expected side of a desync report.
/// Errors: kOutOfRange for a seq outside the history; apply()'s.
Result<Terrain> stateAt(const journal::JournalHistory& history, std::uint64_t seq);

} // namespace terrain::replay
