#pragma once

// The engine under terrain-replay's live replay and soak: a real Server (this build, loopback,
// its own thread) started from a given state, one client feeding it ops from a source, and N
// clients (the feeder among them) applying what it broadcasts. After every op each client
// applies, its world hash is compared with the expected one when the caller knows it (a
// recorded journal's) and can be kept per seq (to compare with the server's own journal
// afterwards). The feeder keeps at most `window` ops in flight ahead of the slowest client, so
// no client is pushed into a snapshot resync that would skip seqs unchecked. Bounded run time.

#include <terrain/client/replica.h>
#include <terrain/deform_op.h>
#include <terrain/journal/journal.h>
#include <terrain/result.h>
#include <terrain/terrain.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace terrain::replay {

struct LiveRunOptions {
    std::size_t clients = 4;           ///< clients checked at every seq, the feeder included
    double time_limit_seconds = 600.0; ///< the run stops here, finished or not
    std::size_t window = 64;           ///< ops in flight ahead of the slowest client
    bool batch_broadcasts = false;     ///< the server's --batch-broadcasts
    bool keep_hashes = false;          ///< ClientTally::hashes, every seq's (8 bytes each)
    /// Called before each client's check at each seq (tests corrupt a replica here).
    std::function<void(std::size_t client, std::uint64_t seq, client::Replica& replica)>
        before_check;
};

/// What one client saw.
struct ClientTally {
    std::string name;
    std::uint64_t checked = 0;    ///< seqs this client applied and hashed
    std::uint64_t mismatches = 0; ///< of those, seqs where it differed from the expected hash
    std::uint64_t repairs = 0;    ///< tile repairs that restored the server's hash
    std::uint64_t snapshots = 0;  ///< whole-state loads (the join, and any resync)
    std::uint64_t server_mismatches = 0; ///< ops whose hash differed from the server's
    std::uint64_t final_seq = 0;
    std::uint64_t final_hash = 0;
    std::string last_disconnect;       ///< empty unless the link dropped
    std::vector<std::uint64_t> hashes; ///< with keep_hashes: [seq - base_seq - 1], 0 if unseen
};

/// The first seq where a client's world differed from the expected one.
struct Divergence {
    std::uint64_t seq = 0;
    DeformOp op;
    std::size_t client = 0;
    /// True when the client had verified this seq's hash equal to the live server's and still
    /// held that state: the server itself (this build) differs from the expectation. False
    /// when the client differs from the server it follows, or (batched broadcasts) had no
    /// server hash for this op.
    bool server_differs = false;
    std::uint64_t expected_hash = 0;
    std::uint64_t observed_hash = 0;
    std::optional<Terrain> observed; ///< the client's state at seq, copied before any repair
};

struct LiveRunResult {
    std::uint64_t base_seq = 0;
    std::uint64_t last_seq = 0;       ///< the server's seq after the last accepted op
    std::uint64_t ops_fed = 0;        ///< requests the feeder sent
    std::uint64_t ops_accepted = 0;   ///< of those, ops the server accepted
    std::uint64_t ops_renumbered = 0; ///< accepted at another seq than the caller expected
    std::map<std::string, std::uint64_t> refusals; ///< by reason ("REASON_...")
    std::string first_refusal;                     ///< "request N: reason" of the first
    double seconds = 0.0;
    bool timed_out = false;
    std::vector<ClientTally> clients;
    std::optional<Divergence> first_divergence;

    std::uint64_t refused() const;
};

/// One request: a canonical op (a journal's), or metres as a player sends them (untrusted).
using FeedRequest = std::variant<DeformOp, OpRequest>;

struct LiveRunInput {
    const Terrain* base = nullptr; ///< the server's state at start
    std::uint64_t base_seq = 0;
    /// The next request, or nothing at the end. `feeder` is the feeder's replica as it is now
    /// (a source aiming at the current ground reads it).
    std::function<std::optional<FeedRequest>(const client::Replica& feeder)> next;
    /// The hash expected after op `seq`, when known (a recorded journal's).
    std::function<std::optional<std::uint64_t>(std::uint64_t seq)> expected_hash;
    /// The op at `seq`, for the divergence record (a journal's; without it the record's op is
    /// left empty).
    std::function<std::optional<DeformOp>(std::uint64_t seq)> expected_op;
    /// Stop feeding at the first refusal or renumbering (a journal replay must be exact).
    bool stop_on_refusal = false;
    /// The server's journal; null: none (ops acknowledged without durability).
    journal::Journal* journal = nullptr;
};

/// Errors: kOutOfRange (no clients, no window, no base state, no source); the server's kIo.
Result<LiveRunResult> runLive(const LiveRunInput& input, const LiveRunOptions& options);

} // namespace terrain::replay
