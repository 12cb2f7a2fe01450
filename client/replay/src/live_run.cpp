#include <terrain/client/connection.h>
#include <terrain/replay/live_run.h>
#include <terrain/server/auth_token.h>
#include <terrain/server/server_thread.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <memory>

namespace terrain::replay {
namespace {

/// One checked client: its replica, its link, and what it saw.
struct Client {
    client::Replica replica;
    std::shared_ptr<client::Connection> connection;
    ClientTally tally;
};

/// The server's events are not the run's output; a session closed for a reason other than
/// the final drain shows in the client's tally.
class QuietLog : public server::LogSink {
  public:
    void write(const server::LogEvent&) override {}
};

/// "REASON_RATE_LIMITED: ..." -> "REASON_RATE_LIMITED"
std::string reasonName(const std::string& reason) {
    return reason.substr(0, reason.find(':'));
}

} // namespace

std::uint64_t LiveRunResult::refused() const {
    std::uint64_t n = 0;
    for (const auto& [reason, count] : refusals)
        n += count;
    return n;
}

Result<LiveRunResult> runLive(const LiveRunInput& input, const LiveRunOptions& options) {
    if (options.clients == 0)
        return makeError(ErrorCode::kOutOfRange, "clients must be at least 1");
    if (options.window == 0)
        return makeError(ErrorCode::kOutOfRange, "window must be at least 1");
    if (!input.base || !input.next)
        return makeError(ErrorCode::kOutOfRange, "a live run needs a base state and an op source");
    const auto started = std::chrono::steady_clock::now();
    const auto deadline = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>(options.time_limit_seconds));

    // the server: this build, from the base state
    server::ServerThreadOptions server_options;
    server_options.seq = input.base_seq;
    server_options.journal = input.journal;
    server_options.log = std::make_shared<QuietLog>();
    server_options.transport.bind_address = "127.0.0.1";
    server_options.transport.port = 0;
    server::ServerConfig& config = server_options.config;
    config.token_secret = server::randomTokenSecret();
    config.deform_rate_per_second = 1e9; // the source's pace is not ours to police
    config.deform_burst = 1e9;
    config.frame_rate_per_second = 1e9; // the feeder is ours: no flood limit
    config.frame_burst = 1e9;
    config.batch_broadcasts = options.batch_broadcasts;
    config.max_sessions = options.clients + 1;
    config.outbound_budget_bytes = std::size_t{256} << 20; // flow control is the feeder's
    auto server = server::ServerThread::start(*input.base, server_options);
    if (!server)
        return server.error();

    LiveRunResult result;
    result.base_seq = input.base_seq;
    result.last_seq = input.base_seq;
    const std::int64_t expiry = static_cast<std::int64_t>(std::time(nullptr)) + 7 * 24 * 3600;

    asio::io_context io;
    std::vector<std::unique_ptr<Client>> clients;
    for (std::size_t i = 0; i < options.clients; ++i) {
        auto c = std::make_unique<Client>();
        c->tally.name = i == 0 ? "feeder" : "client-" + std::to_string(i);
        client::ConnectionConfig cc;
        cc.port = (*server)->port();
        cc.client_name = "terrain-replay " + c->tally.name;
        cc.token = server::mintToken(
            {i + 1, i == 0 ? server::Role::kDeformer : server::Role::kViewer, expiry},
            config.token_secret);
        cc.reconnect_delay_seconds = 0.05;
        c->connection = std::make_shared<client::Connection>(io, cc, c->replica);
        Client* self = c.get();
        const std::size_t index = i;
        c->connection->on_applied = [&, self, index](std::uint64_t seq) {
            // after a snapshot (the join, a resync) nothing was applied to check
            const bool snapshot = self->replica.stats().snapshots > self->tally.snapshots;
            self->tally.snapshots = self->replica.stats().snapshots;
            if (snapshot || seq <= result.base_seq)
                return;
            if (options.before_check)
                options.before_check(index, seq, self->replica);
            ++self->tally.checked;
            const std::uint64_t hash = self->replica.worldHash();
            if (options.keep_hashes) {
                const std::size_t at = seq - result.base_seq - 1;
                if (self->tally.hashes.size() <= at)
                    self->tally.hashes.resize(at + 1, 0);
                self->tally.hashes[at] = hash;
            }
            const std::optional<std::uint64_t> expected =
                input.expected_hash ? input.expected_hash(seq) : std::nullopt;
            if (!expected || *expected == hash)
                return;
            ++self->tally.mismatches;
            if (result.first_divergence)
                return;
            Divergence d;
            d.seq = seq;
            d.client = index;
            // the replica checked this op against the server's hash and holds that state still
            d.server_differs =
                self->replica.verifiedSeq() == seq && self->replica.verifiedHash() == hash;
            d.expected_hash = *expected;
            d.observed_hash = hash;
            d.observed.emplace(self->replica.terrain());
            result.first_divergence = std::move(d);
        };
        c->connection->on_disconnect = [self](const std::string& why) {
            self->tally.last_disconnect = why;
        };
        clients.push_back(std::move(c));
    }
    for (auto& c : clients)
        c->connection->start();

    Client& feeder = *clients.front();
    // a refusal is answered at once, an acceptance after its group commit: answers may
    // overtake each other, and only their count and seqs matter here
    std::size_t answered = 0;
    bool source_done = false;
    bool stop_feeding = false;
    feeder.connection->on_deform_reply = [&](const client::DeformAnswer& a) {
        ++answered;
        if (a.accepted) {
            ++result.ops_accepted;
            if (a.seq != result.last_seq + 1) {
                ++result.ops_renumbered;
                if (input.stop_on_refusal)
                    stop_feeding = true;
            }
            result.last_seq = std::max(result.last_seq, a.seq);
            return;
        }
        ++result.refusals[reasonName(a.reason)];
        if (result.first_refusal.empty())
            result.first_refusal = "request " + std::to_string(a.request_id) + ": " + a.reason;
        if (input.stop_on_refusal)
            stop_feeding = true;
    };
    auto slowest = [&] {
        std::uint64_t seq = result.last_seq;
        for (const auto& c : clients)
            seq = std::min(seq, c->replica.ready() ? c->replica.seq() : 0);
        return seq;
    };
    auto finished = [&] {
        return (source_done || stop_feeding) && answered == result.ops_fed &&
               slowest() == result.last_seq;
    };
    while (!finished()) {
        if (std::chrono::steady_clock::now() > deadline) {
            result.timed_out = true;
            break;
        }
        const bool all_joined = std::all_of(clients.begin(), clients.end(), [](const auto& c) {
            return c->replica.ready() && c->connection->synced();
        });
        if (all_joined) {
            // requests not yet answered count as ops ahead of the slowest client
            while (!source_done && !stop_feeding &&
                   (result.ops_fed - answered) + (result.last_seq - slowest()) < options.window) {
                std::optional<FeedRequest> request = input.next(feeder.replica);
                if (!request) {
                    source_done = true;
                    break;
                }
                if (const DeformOp* op = std::get_if<DeformOp>(&*request))
                    feeder.connection->requestDeform(*op);
                else
                    feeder.connection->requestDeform(std::get<OpRequest>(*request));
                ++result.ops_fed;
            }
        }
        io.run_for(std::chrono::milliseconds(5));
    }
    if (result.first_divergence && input.expected_op)
        result.first_divergence->op =
            input.expected_op(result.first_divergence->seq).value_or(DeformOp{});
    for (auto& c : clients) {
        c->tally.repairs = c->replica.stats().repairs;
        c->tally.snapshots = c->replica.stats().snapshots;
        c->tally.server_mismatches = c->replica.stats().hash_mismatches;
        c->tally.final_seq = c->replica.ready() ? c->replica.seq() : 0;
        c->tally.final_hash = c->replica.worldHash();
        c->connection->stop();
        result.clients.push_back(std::move(c->tally));
    }
    io.run_for(std::chrono::milliseconds(20)); // let the goodbyes go out
    (*server)->stop(0.2);
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return result;
}

} // namespace terrain::replay
