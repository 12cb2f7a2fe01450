#include <terrain/client/client_machine.h>
#include <terrain/wire/op_batch.h>

#include <algorithm>
#include <cstdio>

namespace terrain::client {
namespace pb = wire::pb;

namespace {

// reasons after which reconnecting cannot help
bool isFinal(pb::Reason reason) {
    return reason == pb::REASON_BAD_TOKEN || reason == pb::REASON_BAD_VERSION ||
           reason == pb::REASON_NOT_PERMITTED;
}

} // namespace

ClientMachine::ClientMachine(ConnectionConfig config, Replica& replica)
    : config_(std::move(config)), replica_(replica), reader_(config_.max_frame_bytes),
      assembler_(config_.max_snapshot_bytes), pacer_(config_.pacing) {}

void ClientMachine::linkUp() {
    reader_ = wire::FrameReader(config_.max_frame_bytes);
    assembler_.reset();
    out_.clear();
    drop_.reset();
    awaiting_snapshot_ = false;
    repair_in_flight_ = false;
    phase_ = Phase::kJoining;
    pb::Envelope hello;
    pb::Hello* h = hello.mutable_hello();
    h->set_protocol_version(wire::kProtocolVersion);
    h->set_token(config_.token);
    h->set_client_name(config_.client_name);
    if (replica_.ready()) {
        // resume from the last state both sides agreed on
        h->set_has_last_seq(true);
        h->set_last_seq(replica_.diverged() ? replica_.verifiedSeq() : replica_.seq());
        h->set_last_hash(replica_.diverged() ? replica_.verifiedHash() : replica_.worldHash());
    }
    h->set_genesis_hash(namedGenesis());
    send(hello);
}

void ClientMachine::linkDown() {
    phase_ = Phase::kOffline;
    drop_.reset();
    out_.clear();
    inbox_.clear(); // the resume asks for them again from the replica's seq
    pacer_.reset();
    awaiting_snapshot_ = false;
    repair_in_flight_ = false;
}

void ClientMachine::lose(std::string why, bool final_reason) {
    if (!drop_)
        drop_ = Drop{std::move(why), final_reason};
}

void ClientMachine::receive(std::span<const std::uint8_t> bytes, std::uint64_t now_ns) {
    while (!bytes.empty() && !drop_ && phase_ != Phase::kOffline) {
        const std::size_t n = std::min<std::size_t>(bytes.size(), 64 << 10);
        std::span<std::uint8_t> space = reader_.prepare(n);
        std::copy_n(bytes.begin(), n, space.begin());
        received(n, now_ns);
        bytes = bytes.subspan(n);
    }
}

void ClientMachine::received(std::size_t n, std::uint64_t now_ns) {
    if (drop_ || phase_ == Phase::kOffline)
        return;
    stats_.bytes_in += n;
    reader_.commit(n);
    drainFrames(now_ns);
}

void ClientMachine::drainFrames(std::uint64_t now_ns) {
    while (!drop_) {
        auto next = reader_.next();
        if (!next) {
            lose("bad frame from the server: " + next.error().message, false);
            return;
        }
        if (!next->has_value())
            return;
        ++stats_.frames_in;
        const std::size_t frame_bytes = (*next)->size() + wire::framePrefixSize((*next)->size());
        Result<pb::Envelope> envelope = wire::decodeEnvelope(**next);
        if (!envelope) {
            lose("bad frame from the server: " + envelope.error().message, false);
            return;
        }
        if (envelope->has_op_applied())
            onOpApplied(envelope->op_applied(), frame_bytes);
        else if (envelope->has_op_batch())
            onOpBatch(envelope->op_batch(), frame_bytes);
        else
            handle(*envelope, now_ns);
    }
}

void ClientMachine::handle(const pb::Envelope& envelope, std::uint64_t now_ns) {
    switch (envelope.body_case()) {
    case pb::Envelope::kWelcome:
        onWelcome(envelope.welcome());
        break;
    case pb::Envelope::kSnapshotBegin:
        inbox_.clear(); // the snapshot replaces what they would have made
        pacer_.reset();
        if (Status s = assembler_.begin(envelope.snapshot_begin()); !s)
            lose("snapshot: " + s.error().message, false);
        break;
    case pb::Envelope::kSnapshotChunk:
        onSnapshotChunk(envelope.snapshot_chunk());
        break;
    case pb::Envelope::kRepairState:
        onRepairState(envelope.repair_state());
        break;
    case pb::Envelope::kDeformReply: {
        const pb::DeformReply& r = envelope.deform_reply();
        DeformAnswer a;
        a.request_id = r.request_id();
        a.accepted = r.has_accepted_seq() || r.result_case() == pb::DeformReply::kAcceptedSeq;
        a.seq = r.accepted_seq();
        if (r.has_refused())
            a.reason = wire::describe(r.refused().reason(), r.refused().message());
        if (on_deform_reply)
            on_deform_reply(a);
        break;
    }
    case pb::Envelope::kHeightReply: {
        const pb::HeightReply& r = envelope.height_reply();
        HeightAnswer a{
            r.request_id(), r.inside(), r.height(), {r.normal_x(), r.normal_y(), r.normal_z()}, {}};
        if (r.has_refused())
            a.refused = wire::describe(r.refused().reason(), r.refused().message());
        if (on_height_reply)
            on_height_reply(a);
        break;
    }
    case pb::Envelope::kRayReply: {
        const pb::RayReply& r = envelope.ray_reply();
        RayAnswer a;
        a.request_id = r.request_id();
        a.hit = r.hit();
        a.point[0] = r.x();
        a.point[1] = r.y();
        a.point[2] = r.z();
        a.distance = r.distance();
        if (r.has_refused())
            a.refused = wire::describe(r.refused().reason(), r.refused().message());
        if (on_ray_reply)
            on_ray_reply(a);
        break;
    }
    case pb::Envelope::kPong:
        if (ping_sent_ns_ != 0 && now_ns >= ping_sent_ns_)
            rtt_ = static_cast<double>(now_ns - ping_sent_ns_) * 1e-9;
        break;
    case pb::Envelope::kDisconnect:
        last_disconnect_ =
            wire::describe(envelope.disconnect().reason(), envelope.disconnect().message());
        lose(last_disconnect_, isFinal(envelope.disconnect().reason()));
        break;
    default:
        lose("the server sent a client-only message", false);
        break;
    }
}

void ClientMachine::onWelcome(const pb::Welcome& w) {
    player_id_ = w.player_id();
    role_ = w.role();
    Result<WorldSpec> spec = wire::specFromWire(w.world());
    if (!spec) {
        lose("the server's world is invalid: " + spec.error().message, false);
        return;
    }
    // a snapshot can never be larger than this world's densest encoding
    assembler_.setMaxRawBytes(static_cast<std::size_t>(
        std::min<std::uint64_t>(config_.max_snapshot_bytes, wire::maxSnapshotOrDeltaBytes(*spec))));
    if (w.resume()) {
        ++stats_.resumes;
        phase_ = Phase::kLive;
        const std::uint64_t from = replica_.diverged() ? replica_.verifiedSeq() : replica_.seq();
        const bool too_long = config_.max_replay_ops != 0 && w.server_seq() > from &&
                              w.server_seq() - from > config_.max_replay_ops;
        // resumed from the verified seq: the rest is suspect; or more ops than this client
        // replays faster than it downloads a snapshot (the ops on their way are skipped)
        if (replica_.diverged() || too_long)
            requestSnapshot();
    }
}

void ClientMachine::onSnapshotChunk(const pb::SnapshotChunk& chunk) {
    if (Status s = assembler_.add(chunk); !s) {
        lose("snapshot: " + s.error().message, false);
        return;
    }
    stats_.snapshot_bytes += chunk.data().size();
    if (!assembler_.complete())
        return;
    const bool delta = assembler_.genesisHash() != 0;
    Result<DecodedSnapshot> snapshot =
        assembler_.finish(replica_.ready() ? &replica_.terrain() : nullptr);
    if (!snapshot && delta) {
        // our genesis is not the one the delta was made on: the whole world instead
        std::printf(
            "connection: genesis delta refused (%s); asking for the whole snapshot\n",
            snapshot.error().message.c_str());
        genesis_refused_ = true;
        awaiting_snapshot_ = false;
        requestSnapshot();
        return;
    }
    if (!snapshot) {
        lose("snapshot refused: " + snapshot.error().message, false);
        return;
    }
    ++stats_.snapshots;
    if (delta)
        ++stats_.genesis_deltas;
    const std::uint64_t seq = snapshot->sequence;
    inbox_.clear(); // older than the snapshot
    pacer_.reset();
    replica_.loadSnapshot(std::move(*snapshot));
    awaiting_snapshot_ = false;
    repair_in_flight_ = false;
    repair_rounds_ = 0;
    phase_ = Phase::kLive;
    if (on_applied)
        on_applied(seq);
}

void ClientMachine::onOpApplied(const pb::OpApplied& op, std::size_t frame_bytes) {
    stats_.op_bytes_in += frame_bytes;
    if (awaiting_snapshot_ || assembler_.active() || !replica_.ready())
        return; // superseded by the snapshot on its way
    Result<DeformOp> decoded = wire::opFromWire(op);
    if (!decoded) {
        lose("bad op from the server: " + decoded.error().message, false);
        return;
    }
    // an implicit seq follows the last op received, applied or still waiting
    const std::uint64_t seq =
        wire::appliedSeq(op, inbox_.empty() ? replica_.seq() : inbox_.back().seq);
    if (config_.pacing.paced()) {
        inbox_.push_back({seq, *decoded, op.world_hash()});
        return;
    }
    applyOne(seq, *decoded, op.world_hash());
}

void ClientMachine::onOpBatch(const pb::OpBatch& batch, std::size_t frame_bytes) {
    stats_.op_bytes_in += frame_bytes;
    ++stats_.op_batches;
    if (awaiting_snapshot_ || assembler_.active() || !replica_.ready())
        return; // superseded by the snapshot on its way
    Result<std::vector<wire::BatchedOp>> ops =
        wire::batchFromWire(batch, inbox_.empty() ? replica_.seq() : inbox_.back().seq);
    if (!ops) {
        lose("bad op batch from the server: " + ops.error().message, false);
        return;
    }
    for (const wire::BatchedOp& b : *ops) {
        if (config_.pacing.paced()) {
            inbox_.push_back({b.seq, b.op, b.world_hash});
            continue;
        }
        applyOne(b.seq, b.op, b.world_hash);
        if (drop_ || awaiting_snapshot_)
            return; // the rest is superseded (a snapshot was asked for, or the link closes)
    }
}

void ClientMachine::applyOne(
    std::uint64_t seq, const DeformOp& op, std::optional<std::uint64_t> world_hash) {
    Result<Replica::OpOutcome> outcome = replica_.applyOp(seq, op, world_hash);
    if (!outcome) {
        // a gap or an op our state cannot take: start again from a snapshot
        requestSnapshot();
        return;
    }
    if (*outcome == Replica::OpOutcome::kDiverged && !repair_in_flight_)
        requestRepair(replica_.suspectTiles(), true);
    if (*outcome != Replica::OpOutcome::kStale && on_applied)
        on_applied(seq);
}

std::size_t ClientMachine::applyWaiting(std::size_t count) {
    std::size_t applied = 0;
    // a failed apply asks for a snapshot, which empties the inbox
    while (applied < count && !inbox_.empty()) {
        const Arrived a = std::move(inbox_.front());
        inbox_.pop_front();
        applyOne(a.seq, a.op, a.world_hash);
        ++applied;
    }
    return applied;
}

std::size_t ClientMachine::applyArrived() {
    return applyWaiting(pacer_.take(inbox_.size()));
}

std::size_t ClientMachine::applyAllArrived() {
    pacer_.reset();
    return applyWaiting(inbox_.size());
}

void ClientMachine::onRepairState(const pb::RepairState& state) {
    // the repair is at the seq of the last op before it on the stream; an op of those that
    // diverges asks for no second repair while this one is being handled
    applyAllArrived();
    repair_in_flight_ = false;
    if (!replica_.ready() || awaiting_snapshot_)
        return;
    // at most the tiles asked for: bounds what the reply may make this client allocate
    Result<std::vector<TileRecord>> tiles = wire::decodeTiles(
        {reinterpret_cast<const std::uint8_t*>(state.tiles().data()), state.tiles().size()},
        state.raw_bytes(), replica_.terrain().spec(), repair_tiles_requested_);
    if (!tiles) {
        requestSnapshot();
        return;
    }
    const std::vector<std::uint64_t> hashes(state.tile_hashes().begin(), state.tile_hashes().end());
    Result<std::vector<std::int32_t>> remaining =
        replica_.applyRepair(state.seq(), state.world_hash(), std::move(*tiles), hashes);
    if (!remaining) {
        requestSnapshot();
        return;
    }
    if (remaining->empty()) {
        repair_rounds_ = 0;
        return;
    }
    if (++repair_rounds_ >= config_.max_repair_rounds) {
        requestSnapshot();
        return;
    }
    requestRepair(std::move(*remaining), true);
}

void ClientMachine::requestRepair(std::vector<std::int32_t> tiles, bool want_hashes) {
    ++stats_.repair_requests;
    repair_in_flight_ = true;
    pb::Envelope request;
    pb::RepairRequest* r = request.mutable_repair_request();
    r->set_seq(replica_.seq());
    // the rest are found again by the tile hash comparison of the next round
    if (tiles.size() > config_.max_repair_tiles)
        tiles.resize(config_.max_repair_tiles);
    repair_tiles_requested_ = tiles.size();
    for (std::int32_t t : tiles)
        r->add_tiles(static_cast<std::uint32_t>(t));
    r->set_want_tile_hashes(want_hashes);
    send(request);
}

void ClientMachine::requestSnapshot() {
    if (awaiting_snapshot_)
        return;
    awaiting_snapshot_ = true;
    inbox_.clear(); // the snapshot supersedes them
    pacer_.reset();
    pb::Envelope request;
    request.mutable_snapshot_request()->set_genesis_hash(namedGenesis());
    send(request);
}

std::uint64_t ClientMachine::namedGenesis() const {
    if (!config_.genesis_deltas || genesis_refused_)
        return 0;
    return replica_.genesisHash();
}

std::uint32_t ClientMachine::requestDeform(const OpRequest& request) {
    if (!canSend())
        return 0;
    pb::Envelope envelope;
    pb::DeformRequest* r = envelope.mutable_deform();
    const std::uint32_t id = next_request_id_++;
    r->set_request_id(id);
    wire::requestToWire(request, *r->mutable_metres());
    send(envelope);
    return id;
}

std::uint32_t ClientMachine::requestDeform(const DeformOp& op) {
    if (!canSend())
        return 0;
    pb::Envelope envelope;
    pb::DeformRequest* r = envelope.mutable_deform();
    const std::uint32_t id = next_request_id_++;
    r->set_request_id(id);
    wire::opToWire(op, *r->mutable_canonical());
    send(envelope);
    return id;
}

std::uint32_t ClientMachine::queryHeight(double x, double y) {
    if (!canSend())
        return 0;
    pb::Envelope envelope;
    const std::uint32_t id = next_request_id_++;
    envelope.mutable_height_query()->set_request_id(id);
    envelope.mutable_height_query()->set_x(x);
    envelope.mutable_height_query()->set_y(y);
    send(envelope);
    return id;
}

std::uint32_t
ClientMachine::castRay(const double origin[3], const double direction[3], double max_distance) {
    if (!canSend())
        return 0;
    pb::Envelope envelope;
    pb::RayQuery* q = envelope.mutable_ray_query();
    const std::uint32_t id = next_request_id_++;
    q->set_request_id(id);
    q->set_origin_x(origin[0]);
    q->set_origin_y(origin[1]);
    q->set_origin_z(origin[2]);
    q->set_dir_x(direction[0]);
    q->set_dir_y(direction[1]);
    q->set_dir_z(direction[2]);
    q->set_max_distance(max_distance);
    send(envelope);
    return id;
}

void ClientMachine::ping(std::uint64_t now_ns) {
    pb::Envelope envelope;
    ping_sent_ns_ = now_ns;
    envelope.mutable_ping()->set_nonce(now_ns);
    send(envelope);
}

bool ClientMachine::canSend() {
    if (phase_ != Phase::kOffline && !drop_)
        return true;
    // said at once, not dropped in silence: a game must not wait for an answer that cannot come
    refusal_ = drop_ ? "NOT_CONNECTED: the link is closing (" + drop_->why + "); nothing was sent"
                     : "NOT_CONNECTED: no link to the server is up (connecting, or waiting to "
                       "reconnect); nothing was sent";
    return false;
}

void ClientMachine::send(const pb::Envelope& envelope) {
    if (phase_ == Phase::kOffline || drop_)
        return; // a ping or a protocol frame while offline: the next link starts afresh
    wire::appendFrame(envelope, out_);
}

} // namespace terrain::client
