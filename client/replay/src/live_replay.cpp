#include <terrain/client/connection.h>
#include <terrain/replay/live_replay.h>
#include <terrain/server/auth_token.h>
#include <terrain/server/server_thread.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <memory>
#include <random>

namespace terrain::replay {
namespace {

/// One checked client: its replica, its link, and what it saw.
struct Client {
    client::Replica replica;
    std::shared_ptr<client::Connection> connection;
    ClientTally tally;
};

/// The server's events are not the replay's output; a session closed for a reason other than
/// the final drain shows in the client's tally.
class QuietLog : public server::LogSink {
  public:
    void write(const server::LogEvent&) override {}
};

std::vector<std::uint8_t> randomSecret() {
    std::random_device device;
    std::vector<std::uint8_t> secret(32);
    for (std::uint8_t& b : secret)
        b = static_cast<std::uint8_t>(device());
    return secret;
}

} // namespace

bool LiveReplayResult::agreed() const {
    if (timed_out || ops_refused > 0 || first_divergence)
        return false;
    const std::uint64_t ops = last_seq - base_seq;
    return std::all_of(clients.begin(), clients.end(), [&](const ClientTally& c) {
        return c.checked == ops && c.mismatches == 0 && c.final_seq == last_seq;
    });
}

Result<Terrain> stateAt(const journal::JournalHistory& history, std::uint64_t seq) {
    if (seq < history.base_seq || seq > history.base_seq + history.records.size())
        return makeError(
            ErrorCode::kOutOfRange, "seq " + std::to_string(seq) + " is outside the journal (" +
                                        std::to_string(history.base_seq) + ".." +
                                        std::to_string(history.base_seq + history.records.size()) +
                                        ")");
    Terrain state = history.base;
    for (const journal::JournalRecord& record : history.records) {
        if (record.seq > seq)
            break;
        if (auto applied = state.apply(record.op); !applied)
            return applied.error();
    }
    return state;
}

Result<LiveReplayResult>
runLiveReplay(const journal::JournalHistory& history, const LiveReplayOptions& options) {
    if (options.clients == 0)
        return makeError(ErrorCode::kOutOfRange, "clients must be at least 1");
    if (options.window == 0)
        return makeError(ErrorCode::kOutOfRange, "window must be at least 1");
    const auto started = std::chrono::steady_clock::now();
    const auto deadline = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>(options.time_limit_seconds));

    // the server: this build, from the journal's base state, no journal of its own
    server::ServerThreadOptions server_options;
    server_options.seq = history.base_seq;
    server::ServerConfig& config = server_options.config;
    config.bind_address = "127.0.0.1";
    config.port = 0;
    config.token_secret = randomSecret();
    config.deform_rate_per_second = 1e9; // the journal's pace is not ours to police
    config.deform_burst = 1e9;
    config.batch_broadcasts = options.batch_broadcasts;
    config.max_sessions = options.clients + 1;
    config.outbound_budget_bytes = std::size_t{256} << 20; // flow control is the feeder's
    server_options.log = std::make_shared<QuietLog>();
    auto server = server::ServerThread::start(history.base, server_options);
    if (!server)
        return server.error();

    LiveReplayResult result;
    result.base_seq = history.base_seq;
    result.last_seq = history.base_seq + history.records.size();
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
            if (snapshot || seq <= result.base_seq || seq > result.last_seq)
                return;
            if (options.before_check)
                options.before_check(index, seq, self->replica);
            const journal::JournalRecord& record = history.records[seq - result.base_seq - 1];
            ++self->tally.checked;
            const std::uint64_t hash = self->replica.worldHash();
            if (hash == record.world_hash)
                return;
            ++self->tally.mismatches;
            if (result.first_divergence)
                return;
            Divergence d;
            d.seq = seq;
            d.op = record.op;
            d.client = index;
            // the replica checked this op against the server's hash and holds that state still
            d.server_differs =
                self->replica.verifiedSeq() == seq && self->replica.verifiedHash() == hash;
            d.journal_hash = record.world_hash;
            d.observed_hash = hash;
            d.observed.emplace(self->replica.terrain());
            result.first_divergence = std::move(d);
        };
        c->connection->on_disconnect = [self](const std::string& why) {
            self->tally.last_disconnect = why;
        };
        clients.push_back(std::move(c));
    }
    // the join snapshot is counted as it lands; start after wiring every callback
    for (auto& c : clients)
        c->connection->start();

    Client& feeder = *clients.front();
    std::size_t next = 0;     // next record to send
    std::size_t answered = 0; // replies received
    feeder.connection->on_deform_reply = [&](const client::DeformAnswer& a) {
        const journal::JournalRecord& record = history.records[answered++];
        if (a.accepted && a.seq == record.seq)
            return;
        if (++result.ops_refused == 1)
            result.first_refusal =
                "seq " + std::to_string(record.seq) + ": " +
                (a.accepted ? "numbered " + std::to_string(a.seq) + " by the live server"
                            : a.reason);
    };
    auto slowest = [&] {
        std::uint64_t seq = result.last_seq;
        for (const auto& c : clients)
            seq = std::min(seq, c->replica.ready() ? c->replica.seq() : 0);
        return seq;
    };
    auto finished = [&] {
        return answered == history.records.size() && slowest() == result.last_seq;
    };
    while (!finished()) {
        if (std::chrono::steady_clock::now() > deadline) {
            result.timed_out = true;
            break;
        }
        const bool all_joined = std::all_of(clients.begin(), clients.end(), [](const auto& c) {
            return c->replica.ready() && c->connection->synced();
        });
        // a refused op leaves a hole in the numbering: stop feeding, the run has failed
        if (all_joined && result.ops_refused == 0) {
            const std::uint64_t behind = slowest();
            while (next < history.records.size() &&
                   history.records[next].seq <= behind + options.window) {
                feeder.connection->requestDeform(history.records[next].op);
                ++next;
            }
        } else if (result.ops_refused > 0 && answered == next) {
            break;
        }
        io.run_for(std::chrono::milliseconds(5));
    }
    result.ops_fed = next;
    for (auto& c : clients) {
        c->tally.repairs = c->replica.stats().repairs;
        c->tally.snapshots = c->replica.stats().snapshots;
        c->tally.final_seq = c->replica.ready() ? c->replica.seq() : 0;
        c->tally.final_hash = c->replica.worldHash();
        c->connection->stop();
        result.clients.push_back(c->tally);
    }
    io.run_for(std::chrono::milliseconds(20)); // let the goodbyes go out
    (*server)->stop(0.2);
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return result;
}

} // namespace terrain::replay
