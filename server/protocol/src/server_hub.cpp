#include <terrain/assert.h>
#include <terrain/server/server_hub.h>
#include <terrain/server/session_machine.h>
#include <terrain/wire/op_batch.h>

#include <algorithm>
#include <future>
#include <string_view>

namespace terrain::server {
namespace pb = wire::pb;

ServerHub::ServerHub(
    HubHost& host, ServerConfig config, Authority& authority, journal::Journal* journal)
    : host_(host), config_(std::move(config)), authority_(authority), journal_(journal),
      broadcast_seq_(authority.seq()), broadcast_hash_(authority.terrain().worldHash()),
      last_journal_snapshot_seq_(journal ? journal->snapshotSeq() : authority.seq()),
      op_frames_(authority.log().capacity()), genesis_hash_(authority.terrain().genesisHash()) {
    // a log restored after a restart: its ops' broadcast frames, so clients resume from them
    const OpLog& log = authority.log();
    for (std::uint64_t seq = log.resumableFrom() + 1; seq <= log.lastSeq(); ++seq) {
        const LoggedOp& logged = log.at(seq);
        pb::Envelope envelope;
        wire::opToWire(logged.op, seq, logged.world_hash, *envelope.mutable_op_applied());
        op_frames_[seq % op_frames_.size()] = wire::encodeFrame(envelope);
    }
}

namespace {

// "address:port" -> "address" (an IPv6 address keeps its colons)
std::string_view addressOf(std::string_view peer) {
    const std::size_t colon = peer.rfind(':');
    return colon == std::string_view::npos ? peer : peer.substr(0, colon);
}

} // namespace

ServerHub::~ServerHub() {
    *alive_ = false;
    for (const auto& session : sessions_)
        session->abandon();
}

std::shared_ptr<SessionMachine>
ServerHub::addSession(std::string peer, double now, SessionLink* link) {
    auto session =
        std::make_shared<SessionMachine>(*this, next_session_id_++, std::move(peer), now);
    session->attach(link);
    ++stats_.sessions_accepted;
    // connections that have not said Hello have limits of their own, so that sockets that
    // never say it cannot keep players out (player slots are counted at Hello)
    const std::string_view address = addressOf(session->peer());
    std::size_t waiting = 0;
    std::size_t waiting_here = 0;
    for (const auto& s : sessions_)
        if (s->awaitingHello()) {
            ++waiting;
            if (addressOf(s->peer()) == address)
                ++waiting_here;
        }
    sessions_.push_back(session);
    if (waiting >= config_.max_pending_sessions)
        session->close(
            pb::REASON_SERVER_FULL, std::to_string(waiting) +
                                        " connections are waiting to say Hello, the server's "
                                        "limit; try again shortly");
    else if (waiting_here >= config_.max_pending_per_address)
        session->close(
            pb::REASON_SERVER_FULL, std::to_string(waiting_here) + " connections from " +
                                        std::string(address) +
                                        " are waiting to say Hello, the limit for one address");
    return session;
}

void ServerHub::remove(const SessionMachine* session) {
    // deferred: a session may finish while the hub walks the list
    host_.post([this, alive = std::weak_ptr<bool>(alive_), session] {
        if (alive.expired())
            return;
        auto it = std::find_if(
            sessions_.begin(), sessions_.end(), [&](const auto& s) { return s.get() == session; });
        if (it != sessions_.end())
            sessions_.erase(it);
        if (shutting_down_ && sessions_.empty())
            finishDrain();
    });
}

ServerHub::SessionCounts ServerHub::sessionCounts() const {
    SessionCounts c;
    for (const auto& s : sessions_) {
        if (s->awaitingHello())
            ++c.awaiting_hello;
        else if (s->ending())
            ++c.ending;
        else if (s->role() == Role::kViewer)
            ++c.viewers;
        else if (s->role() == Role::kDeformer)
            ++c.deformers;
        else
            ++c.admins;
    }
    return c;
}

std::size_t ServerHub::queuedBytes() const {
    std::size_t n = 0;
    for (const auto& s : sessions_)
        n += s->queuedBytes();
    return n;
}

void ServerHub::submit(
    const std::shared_ptr<SessionMachine>& session,
    std::uint32_t request_id,
    Accepted accepted,
    double received_at,
    double apply_seconds) {
    ++stats_.ops_accepted;
    if (journal_)
        journal_->append(journal::JournalRecord{accepted.seq, accepted.op, accepted.world_hash});
    pending_.push_back(
        PendingOp{std::move(accepted), session, request_id, received_at, apply_seconds});
    scheduleCommit();
}

struct ServerHub::CommitInFlight {
    journal::CommitBatch batch;
    std::promise<Status> written;
    std::shared_future<Status> result = written.get_future().share();
    bool finished = false; ///< finishCommit() ran (the posted completion then skips)
};

void ServerHub::scheduleCommit() {
    if (commit_scheduled_)
        return;
    commit_scheduled_ = true;
    // runs after the handlers that are already ready: they join this group commit
    host_.post([this, alive = std::weak_ptr<bool>(alive_)] {
        if (alive.expired())
            return;
        commit_scheduled_ = false;
        startCommit();
    });
}

void ServerHub::startCommit() {
    if (pending_.empty() || failed_ || commit_in_flight_)
        return; // a group is out: these go with the next one, when it is back
    if (!journal_) {
        std::vector<PendingOp> ops;
        ops.swap(pending_);
        ++stats_.commits;
        broadcast(ops);
        return;
    }
    if (!config_.pipeline_commits) {
        commitPending(); // this thread writes and syncs the group
        return;
    }
    std::optional<journal::CommitBatch> batch = journal_->takeBatch();
    if (!batch) { // pending ops and no record to take: the journal failed earlier
        failJournal(journal_->failure() ? journal_->failure()->message : "no records to commit");
        return;
    }
    auto flight = std::make_shared<CommitInFlight>();
    flight->batch = std::move(*batch);
    commit_in_flight_ = flight;
    committing_.swap(pending_);
    host_.runCommit([this, flight, alive = std::weak_ptr<bool>(alive_)]() -> std::function<void()> {
        flight->written.set_value(journal::writeBatch(flight->batch));
        return [this, flight, alive] {
            if (!alive.expired())
                finishCommit(flight, true);
        };
    });
}

void ServerHub::finishCommit(const std::shared_ptr<CommitInFlight>& flight, bool go_on) {
    if (flight->finished)
        return; // commitPending() finished it while it waited
    flight->finished = true;
    commit_in_flight_.reset();
    if (Status s = journal_->batchWritten(flight->batch, flight->result.get()); !s) {
        // applied but not durable: this state must never be acknowledged or broadcast
        failJournal(s.error().message);
        return;
    }
    ++stats_.commits;
    std::vector<PendingOp> ops;
    ops.swap(committing_);
    broadcast(ops);
    if (go_on)
        startCommit();
}

void ServerHub::commitPending() {
    while (!failed_ && (commit_in_flight_ || !pending_.empty())) {
        if (commit_in_flight_) {
            const std::shared_ptr<CommitInFlight> flight = commit_in_flight_;
            flight->result.wait(); // this thread waits for one write + fdatasync
            finishCommit(flight, false);
            continue;
        }
        if (!journal_) {
            startCommit(); // broadcasts at once
            continue;
        }
        // the rest on this thread
        std::optional<journal::CommitBatch> batch = journal_->takeBatch();
        if (!batch) {
            failJournal(
                journal_->failure() ? journal_->failure()->message : "no records to commit");
            return;
        }
        auto flight = std::make_shared<CommitInFlight>();
        flight->batch = std::move(*batch);
        flight->written.set_value(journal::writeBatch(flight->batch));
        commit_in_flight_ = flight;
        committing_.swap(pending_);
        finishCommit(flight, false);
    }
}

void ServerHub::failJournal(const std::string& why) {
    fail("journal commit failed: " + why);
    for (std::size_t i = 0; i < sessions_.size(); ++i)
        sessions_[i]->close(pb::REASON_UNAVAILABLE, "the server's journal failed");
    committing_.clear();
    pending_.clear();
}

void ServerHub::start() {
    // the copy the journal's snapshots follow, made now: the first snapshot only syncs it
    if (journal_ && !journal_copy_)
        journal_copy_ = std::make_shared<Terrain>(authority_.terrain());
    // the records a recovery replayed are in no snapshot yet: without one, every later start
    // would replay them again
    if (journal_ && !failed_ && !journal_snapshot_in_flight_ &&
        last_journal_snapshot_seq_ != broadcast_seq_) {
        commitPending();
        if (!failed_ && !journal_snapshot_in_flight_)
            writeJournalSnapshot();
    }
}

void ServerHub::maybeWriteJournalSnapshot() {
    const auto due = [this] {
        // shutdown() writes its own snapshot at the last seq
        if (!journal_ || failed_ || shutting_down_ || journal_snapshot_in_flight_ ||
            broadcast_seq_ == last_journal_snapshot_seq_)
            return false;
        const bool by_count =
            config_.journal_snapshot_every > 0 &&
            broadcast_seq_ - last_journal_snapshot_seq_ >= config_.journal_snapshot_every;
        const bool by_time =
            config_.journal_snapshot_replay_seconds > 0 &&
            replay_seconds_since_snapshot_ >= config_.journal_snapshot_replay_seconds;
        return by_count || by_time;
    };
    if (!due())
        return;
    // the snapshot starts a segment after broadcast_seq_: every op before that durable first
    // (this may broadcast more, and write the snapshot from there)
    commitPending();
    if (due())
        writeJournalSnapshot();
}

void ServerHub::fail(const std::string& why) {
    if (failed_)
        return;
    failed_ = true;
    failure_ = why;
    // nobody new may join a state that holds a non-durable op
    host_.stopAccepting();
    LogEvent e;
    e.level = LogLevel::kError;
    e.event = "server.fatal";
    e.message = "FATAL: " + why;
    host_.log(e);
}

void ServerHub::log(LogEvent event) {
    host_.log(event);
}

void ServerHub::broadcast(std::vector<PendingOp>& ops) {
    if (journal_) // what a recovery from the last snapshot would replay
        for (const PendingOp& p : ops)
            replay_seconds_since_snapshot_ += p.apply_seconds;
    if (config_.batch_broadcasts && ops.size() > 1) {
        broadcastBatched(ops);
    } else {
        for (PendingOp& p : ops) {
            const Accepted& a = p.accepted;
            pb::Envelope envelope;
            wire::opToWire(a.op, a.seq, a.world_hash, *envelope.mutable_op_applied());
            wire::Frame frame = wire::encodeFrame(envelope);
            op_frames_[a.seq % op_frames_.size()] = frame;
            broadcast_seq_ = a.seq;
            broadcast_hash_ = a.world_hash;
            for (std::size_t i = 0; i < sessions_.size(); ++i)
                sessions_[i]->sendOp(a.seq, frame);
            acknowledge(p);
        }
    }
    maybeWriteJournalSnapshot();
    if (failed_)
        return;
    // keep the join snapshots warm once joins have asked for them: rebuilt off this thread
    // before they age out, so a join finds a usable one instead of waiting for a build
    for (const JoinSnapshot& cached : join_snapshots_)
        if (cached.frames && !shutting_down_ &&
            broadcast_seq_ - cached.frames->seq >= config_.snapshot_cache_max_lag / 2)
            buildSnapshot();
    if (on_broadcast)
        on_broadcast(broadcast_seq_);
}

void ServerHub::acknowledge(const PendingOp& p) {
    host_.observe(HubTiming::kBroadcast, host_.monotonicSeconds() - p.received_at);
    if (auto requester = p.requester.lock()) {
        pb::Envelope reply;
        reply.mutable_deform_reply()->set_request_id(p.request_id);
        reply.mutable_deform_reply()->set_accepted_seq(p.accepted.seq);
        requester->sendControl(reply);
    }
}

void ServerHub::broadcastBatched(std::vector<PendingOp>& ops) {
    // every op's own frame stays in the ring: tails after a snapshot or a resume replay them
    for (const PendingOp& p : ops) {
        const Accepted& a = p.accepted;
        pb::Envelope envelope;
        wire::opToWire(a.op, a.seq, a.world_hash, *envelope.mutable_op_applied());
        op_frames_[a.seq % op_frames_.size()] = wire::encodeFrame(envelope);
    }
    std::vector<DeformOp> batch_ops;
    std::vector<std::uint64_t> hashes;
    for (std::size_t from = 0; from < ops.size(); from += wire::kMaxBatchOps) {
        const std::size_t to = std::min(ops.size(), from + wire::kMaxBatchOps);
        batch_ops.clear();
        hashes.clear();
        for (std::size_t i = from; i < to; ++i) {
            batch_ops.push_back(ops[i].accepted.op);
            hashes.push_back(ops[i].accepted.world_hash);
        }
        const std::uint64_t first = ops[from].accepted.seq;
        const std::uint64_t last = ops[to - 1].accepted.seq;
        pb::Envelope envelope;
        wire::batchToWire(
            batch_ops, first, hashes, config_.batch_hash_per_op, *envelope.mutable_op_batch());
        const wire::Frame frame = wire::encodeFrame(envelope);
        broadcast_seq_ = last;
        broadcast_hash_ = hashes.back();
        for (std::size_t i = 0; i < sessions_.size(); ++i)
            sessions_[i]->sendOps(first, last, frame);
    }
    // after the ops: a requester reads OpApplied (here, the batch) before its DeformReply
    for (const PendingOp& p : ops)
        acknowledge(p);
}

std::uint64_t ServerHub::resumeWindow() const {
    return std::min<std::uint64_t>(
        op_frames_.size(), config_.outbound_budget_bytes / 2 / kMaxOpFrameBytes);
}

bool ServerHub::tailFits(std::uint64_t ops) const {
    return ops * kMaxOpFrameBytes <= config_.outbound_budget_bytes / 2;
}

const wire::Frame& ServerHub::opFrame(std::uint64_t seq) const {
    return op_frames_[seq % op_frames_.size()];
}

const wire::SnapshotFrames* ServerHub::usableSnapshot(SnapshotKind kind) const {
    const std::uint64_t current = authority_.seq();
    const wire::SnapshotFrames* cached = join_snapshots_[kind].frames.get();
    const bool usable = cached && cached->seq >= authority_.log().resumableFrom() &&
                        current - cached->seq <= config_.snapshot_cache_max_lag &&
                        tailFits(current - cached->seq);
    return usable ? cached : nullptr;
}

void ServerHub::awaitSnapshot(const std::shared_ptr<SessionMachine>& session, SnapshotKind kind) {
    join_snapshots_[kind].waiters.push_back(session);
    join_snapshots_[kind].wanted = true;
    buildSnapshot();
}

void ServerHub::buildSnapshot() {
    if (join_build_in_flight_ || failed_)
        return;
    // a snapshot holds durable ops only: commit what is pending first (inside a broadcast loop
    // nothing is: the batch was committed before it)
    commitPending();
    if (failed_ || join_build_in_flight_)
        return; // failed, or the commit's broadcast started a build
    TERRAIN_ASSERT(pending_.empty() && !commit_in_flight_);
    join_build_in_flight_ = true;
    // bringing the kept copy up to date is this thread's whole share of the work
    std::shared_ptr<const Terrain> terrain = followTerrain(join_copy_);
    std::array<bool, kSnapshotKinds> kinds{};
    for (std::size_t k = 0; k < kSnapshotKinds; ++k)
        kinds[k] = join_snapshots_[k].wanted;
    host_.runSnapshot(
        [this, terrain, kinds, seq = authority_.seq(), genesis = genesis_hash_,
         chunk = config_.snapshot_chunk_bytes,
         alive = std::weak_ptr<bool>(alive_)]() -> std::function<void()> {
            std::array<std::shared_ptr<const wire::SnapshotFrames>, kSnapshotKinds> built;
            if (kinds[kWholeSnapshot])
                built[kWholeSnapshot] = std::make_shared<const wire::SnapshotFrames>(
                    wire::buildSnapshotFrames(*terrain, seq, chunk));
            if (kinds[kGenesisDelta])
                built[kGenesisDelta] = std::make_shared<const wire::SnapshotFrames>(
                    wire::buildGenesisDeltaFrames(*terrain, seq, genesis, chunk));
            return [this, built = std::move(built), alive]() mutable {
                if (!alive.expired())
                    onSnapshotBuilt(std::move(built));
            };
        });
}

std::shared_ptr<const Terrain> ServerHub::followTerrain(std::shared_ptr<Terrain>& kept) const {
    // a copy kept between snapshots follows the world tile by tile (the tiles changed since):
    // a fresh copy of a battle's world cost this thread 4 ms, assignment 1.2 ms, this some
    // microseconds per op since; still held by the last snapshot's thread, it is copied anew
    if (!kept || kept.use_count() > 1)
        kept = std::make_shared<Terrain>(authority_.terrain());
    else
        kept->syncFrom(authority_.terrain());
    return kept;
}

void ServerHub::writeJournalSnapshot() {
    // the journal marks the snapshot's seq (a new segment only once the current one is full)
    // and goes on appending; the file is encoded and written on the snapshot thread, and
    // pruning follows once it is durable
    if (Status s = journal_->beginSnapshot(broadcast_seq_); !s) {
        fail("journal snapshot failed: " + s.error().message);
        return;
    }
    last_journal_snapshot_seq_ = broadcast_seq_;
    replay_seconds_since_snapshot_ = 0.0;
    journal_snapshot_in_flight_ = true;
    std::shared_ptr<const Terrain> terrain = followTerrain(journal_copy_);
    host_.runSnapshot(
        [this, terrain, seq = broadcast_seq_, dir = journal_->directory(),
         alive = std::weak_ptr<bool>(alive_)]() -> std::function<void()> {
            Status written = journal::writeSnapshotFile(dir, *terrain, seq);
            return [this, written = std::move(written), seq, alive] {
                if (alive.expired())
                    return;
                journal_snapshot_in_flight_ = false;
                if (Status s = journal_->snapshotWritten(written); !s) {
                    LogEvent e;
                    e.level = LogLevel::kWarning;
                    e.event = "journal.snapshot_dropped";
                    e.source = "journal";
                    e.message =
                        "snapshot at seq " + std::to_string(seq) +
                        " not kept (the segments still hold every record): " + s.error().message;
                    e.fields.push_back({"seq", std::to_string(seq), true});
                    host_.log(e);
                }
            };
        });
}

void ServerHub::onSnapshotBuilt(
    std::array<std::shared_ptr<const wire::SnapshotFrames>, kSnapshotKinds> built) {
    join_build_in_flight_ = false;
    bool rebuild = false;
    for (std::size_t k = 0; k < kSnapshotKinds; ++k) {
        JoinSnapshot& cache = join_snapshots_[k];
        if (built[k]) {
            ++stats_.snapshots_built;
            if (!cache.frames || built[k]->seq >= cache.frames->seq)
                cache.frames = std::move(built[k]);
        }
        std::vector<std::weak_ptr<SessionMachine>> waiters;
        waiters.swap(cache.waiters);
        const wire::SnapshotFrames* usable = usableSnapshot(static_cast<SnapshotKind>(k));
        for (const auto& waiter : waiters) {
            const std::shared_ptr<SessionMachine> session = waiter.lock();
            // a session that changed the kind it asks for waits in the other list too
            if (!session || !session->awaitingSnapshot() ||
                session->holdsGenesis() != (k == kGenesisDelta))
                continue;
            if (usable)
                session->deliverSnapshot(*usable);
            else
                cache.waiters.push_back(waiter); // not built, or too far behind: the next build
        }
        rebuild = rebuild || !cache.waiters.empty();
    }
    if (rebuild)
        buildSnapshot();
}

void ServerHub::shutdown(std::function<void()> done) {
    if (shutting_down_)
        return;
    shutting_down_ = true;
    host_.stopAccepting();
    commitPending();
    // the newest DURABLE snapshot decides: one begun on the snapshot thread may never be
    // written (its job is dropped when the server stops), and a recovery's state may be in none
    if (journal_ && !failed_ && journal_->snapshotSeq() != broadcast_seq_) {
        if (Status s = journal_->writeSnapshot(authority_.terrain(), broadcast_seq_); !s)
            fail("journal snapshot at shutdown failed: " + s.error().message);
        last_journal_snapshot_seq_ = broadcast_seq_;
        replay_seconds_since_snapshot_ = 0.0;
    }
    shutdown_done_ = std::move(done);
    if (sessions_.empty()) {
        host_.post([this, alive = std::weak_ptr<bool>(alive_)] {
            if (!alive.expired())
                finishDrain();
        });
        return;
    }
    for (std::size_t i = 0; i < sessions_.size(); ++i)
        sessions_[i]->close(pb::REASON_SHUTTING_DOWN, "the server is shutting down");
}

void ServerHub::drainTimedOut() {
    finishDrain();
}

void ServerHub::finishDrain() {
    if (!shutdown_done_)
        return;
    auto done = std::move(shutdown_done_);
    shutdown_done_ = nullptr;
    done();
}

} // namespace terrain::server
