#include <terrain/client/connection.h>
#include <terrain/wire/op_batch.h>

#include <algorithm>
#include <chrono>
#include <cstring>

namespace terrain::client {
namespace pb = wire::pb;

namespace {

std::uint64_t nowNs() {
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::steady_clock::now().time_since_epoch())
                                          .count());
}

// reasons after which reconnecting cannot help
bool isFinal(pb::Reason reason) {
    return reason == pb::REASON_BAD_TOKEN || reason == pb::REASON_BAD_VERSION ||
           reason == pb::REASON_NOT_PERMITTED;
}

} // namespace

Connection::Connection(asio::io_context& io, ConnectionConfig config, Replica& replica)
    : io_(io), config_(std::move(config)), replica_(replica), socket_(io), resolver_(io),
      timer_(io), reader_(config_.max_frame_bytes), assembler_(config_.max_snapshot_bytes),
      pacer_(config_.pacing) {}

Connection::~Connection() = default;

void Connection::start() {
    connect();
}

void Connection::stop() {
    state_ = State::kClosed;
    ++generation_;
    asio::error_code ignored;
    timer_.cancel();
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
}

void Connection::dropForTesting() {
    lost("dropped by the test", false);
}

void Connection::connect() {
    if (state_ == State::kClosed)
        return;
    state_ = State::kConnecting;
    const std::uint64_t gen = ++generation_;
    reader_ = wire::FrameReader(config_.max_frame_bytes);
    assembler_.reset();
    out_.clear();
    writing_.clear();
    write_busy_ = false;
    awaiting_snapshot_ = false;
    repair_in_flight_ = false;
    socket_ = asio::ip::tcp::socket(io_);
    resolver_.async_resolve(
        config_.host, std::to_string(config_.port),
        [self = shared_from_this(), gen](const asio::error_code& ec, auto results) {
            if (gen != self->generation_)
                return;
            if (ec) {
                self->lost("resolve " + self->config_.host + ": " + ec.message(), false);
                return;
            }
            asio::async_connect(
                self->socket_, results,
                [self, gen](const asio::error_code& cec, const asio::ip::tcp::endpoint&) {
                    if (gen != self->generation_)
                        return;
                    if (cec) {
                        self->lost("connect: " + cec.message(), false);
                        return;
                    }
                    self->onConnected();
                });
        });
}

void Connection::onConnected() {
    ++stats_.connects;
    asio::error_code ignored;
    socket_.set_option(asio::ip::tcp::no_delay(true), ignored);
    state_ = State::kJoining;
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
    readMore();
}

void Connection::readMore() {
    const std::uint64_t gen = generation_;
    std::span<std::uint8_t> space = reader_.prepare(64 << 10);
    socket_.async_read_some(
        asio::buffer(space.data(), space.size()),
        [self = shared_from_this(), gen](const asio::error_code& ec, std::size_t n) {
            if (gen != self->generation_)
                return;
            if (ec) {
                self->lost(
                    self->last_disconnect_.empty() ? "read: " + ec.message()
                                                   : self->last_disconnect_,
                    false);
                return;
            }
            self->stats_.bytes_in += n;
            self->reader_.commit(n);
            for (;;) {
                auto next = self->reader_.next();
                if (!next) {
                    self->lost("bad frame from the server: " + next.error().message, false);
                    return;
                }
                if (!next->has_value())
                    break;
                ++self->stats_.frames_in;
                const std::size_t frame_bytes =
                    (*next)->size() + wire::framePrefixSize((*next)->size());
                Result<pb::Envelope> envelope = wire::decodeEnvelope(**next);
                if (!envelope) {
                    self->lost("bad frame from the server: " + envelope.error().message, false);
                    return;
                }
                if (envelope->has_op_applied())
                    self->onOpApplied(envelope->op_applied(), frame_bytes);
                else if (envelope->has_op_batch())
                    self->onOpBatch(envelope->op_batch(), frame_bytes);
                else
                    self->handle(*envelope);
                if (gen != self->generation_)
                    return; // the frame closed this socket
            }
            self->readMore();
        });
}

void Connection::handle(const pb::Envelope& envelope) {
    switch (envelope.body_case()) {
    case pb::Envelope::kWelcome: {
        const pb::Welcome& w = envelope.welcome();
        player_id_ = w.player_id();
        role_ = w.role();
        Result<WorldSpec> spec = wire::specFromWire(w.world());
        if (!spec) {
            lost("the server's world is invalid: " + spec.error().message, false);
            break;
        }
        // a snapshot can never be larger than this world's densest encoding
        assembler_.setMaxRawBytes(static_cast<std::size_t>(std::min<std::uint64_t>(
            config_.max_snapshot_bytes, wire::maxSnapshotOrDeltaBytes(*spec))));
        if (w.resume()) {
            ++stats_.resumes;
            state_ = State::kLive;
            if (replica_.diverged()) // resumed from the verified seq: the rest is suspect
                requestSnapshot();
        }
        break;
    }
    case pb::Envelope::kSnapshotBegin:
        inbox_.clear(); // the snapshot replaces what they would have made
        pacer_.reset();
        if (Status s = assembler_.begin(envelope.snapshot_begin()); !s)
            lost("snapshot: " + s.error().message, false);
        break;
    case pb::Envelope::kSnapshotChunk: {
        if (Status s = assembler_.add(envelope.snapshot_chunk()); !s) {
            lost("snapshot: " + s.error().message, false);
            break;
        }
        stats_.snapshot_bytes += envelope.snapshot_chunk().data().size();
        if (assembler_.complete()) {
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
                break;
            }
            if (!snapshot) {
                lost("snapshot refused: " + snapshot.error().message, false);
                break;
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
            state_ = State::kLive;
            if (on_applied)
                on_applied(seq);
        }
        break;
    }
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
        if (ping_sent_ns_ != 0)
            rtt_ = static_cast<double>(nowNs() - ping_sent_ns_) * 1e-9;
        break;
    case pb::Envelope::kDisconnect: {
        last_disconnect_ =
            wire::describe(envelope.disconnect().reason(), envelope.disconnect().message());
        lost(last_disconnect_, isFinal(envelope.disconnect().reason()));
        break;
    }
    default:
        lost("the server sent a client-only message", false);
        break;
    }
}

void Connection::onOpApplied(const pb::OpApplied& op, std::size_t frame_bytes) {
    stats_.op_bytes_in += frame_bytes;
    if (awaiting_snapshot_ || assembler_.active() || !replica_.ready())
        return; // superseded by the snapshot on its way
    Result<DeformOp> decoded = wire::opFromWire(op);
    if (!decoded) {
        lost("bad op from the server: " + decoded.error().message, false);
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

void Connection::onOpBatch(const pb::OpBatch& batch, std::size_t frame_bytes) {
    stats_.op_bytes_in += frame_bytes;
    ++stats_.op_batches;
    if (awaiting_snapshot_ || assembler_.active() || !replica_.ready())
        return; // superseded by the snapshot on its way
    Result<std::vector<wire::BatchedOp>> ops =
        wire::batchFromWire(batch, inbox_.empty() ? replica_.seq() : inbox_.back().seq);
    if (!ops) {
        lost("bad op batch from the server: " + ops.error().message, false);
        return;
    }
    const std::uint64_t gen = generation_;
    for (const wire::BatchedOp& b : *ops) {
        if (config_.pacing.paced()) {
            inbox_.push_back({b.seq, b.op, b.world_hash});
            continue;
        }
        applyOne(b.seq, b.op, b.world_hash);
        if (gen != generation_ || awaiting_snapshot_)
            return; // the rest is superseded (a snapshot was asked for, or the link closed)
    }
}

void Connection::applyOne(
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

std::size_t Connection::applyWaiting(std::size_t count) {
    if (count == 0)
        return 0;
    // called from the frame loop, not a handler: an on_applied callback may drop the last
    // owner of this connection
    const std::shared_ptr<Connection> self = shared_from_this();
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

std::size_t Connection::applyArrived() {
    return applyWaiting(pacer_.take(inbox_.size()));
}

std::size_t Connection::applyAllArrived() {
    pacer_.reset();
    return applyWaiting(inbox_.size());
}

void Connection::onRepairState(const pb::RepairState& state) {
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

void Connection::requestRepair(std::vector<std::int32_t> tiles, bool want_hashes) {
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

void Connection::requestSnapshot() {
    if (awaiting_snapshot_)
        return;
    awaiting_snapshot_ = true;
    inbox_.clear(); // the snapshot supersedes them
    pacer_.reset();
    pb::Envelope request;
    request.mutable_snapshot_request()->set_genesis_hash(namedGenesis());
    send(request);
}

std::uint64_t Connection::namedGenesis() const {
    if (!config_.genesis_deltas || genesis_refused_)
        return 0;
    return replica_.genesisHash();
}

std::uint32_t Connection::requestDeform(const OpRequest& request) {
    pb::Envelope envelope;
    pb::DeformRequest* r = envelope.mutable_deform();
    const std::uint32_t id = next_request_id_++;
    r->set_request_id(id);
    wire::requestToWire(request, *r->mutable_metres());
    send(envelope);
    return id;
}

std::uint32_t Connection::requestDeform(const DeformOp& op) {
    pb::Envelope envelope;
    pb::DeformRequest* r = envelope.mutable_deform();
    const std::uint32_t id = next_request_id_++;
    r->set_request_id(id);
    wire::opToWire(op, *r->mutable_canonical());
    send(envelope);
    return id;
}

std::uint32_t Connection::queryHeight(double x, double y) {
    pb::Envelope envelope;
    const std::uint32_t id = next_request_id_++;
    envelope.mutable_height_query()->set_request_id(id);
    envelope.mutable_height_query()->set_x(x);
    envelope.mutable_height_query()->set_y(y);
    send(envelope);
    return id;
}

std::uint32_t
Connection::castRay(const double origin[3], const double direction[3], double max_distance) {
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

void Connection::ping() {
    pb::Envelope envelope;
    ping_sent_ns_ = nowNs();
    envelope.mutable_ping()->set_nonce(ping_sent_ns_);
    send(envelope);
}

void Connection::send(const pb::Envelope& envelope) {
    if (state_ != State::kJoining && state_ != State::kLive)
        return; // requests made while disconnected are dropped; the caller sees no reply
    wire::appendFrame(envelope, out_);
    writeMore();
}

void Connection::writeMore() {
    if (write_busy_ || out_.empty())
        return;
    writing_.swap(out_);
    out_.clear();
    write_busy_ = true;
    const std::uint64_t gen = generation_;
    asio::async_write(
        socket_, asio::buffer(writing_),
        [self = shared_from_this(), gen](const asio::error_code& ec, std::size_t n) {
            if (gen != self->generation_)
                return;
            self->write_busy_ = false;
            self->stats_.bytes_out += n;
            self->writing_.clear();
            if (ec) {
                self->lost("write: " + ec.message(), false);
                return;
            }
            self->writeMore();
        });
}

void Connection::lost(const std::string& why, bool final_reason) {
    if (state_ == State::kClosed)
        return;
    ++stats_.disconnects;
    ++generation_;
    inbox_.clear(); // the resume asks for them again from the replica's seq
    pacer_.reset();
    last_disconnect_ = why;
    asio::error_code ignored;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
    if (on_disconnect)
        on_disconnect(why);
    if (final_reason || !config_.reconnect) {
        state_ = State::kClosed;
        return;
    }
    state_ = State::kWaiting;
    timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(config_.reconnect_delay_seconds)));
    timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
        if (!ec && self->state_ == State::kWaiting)
            self->connect();
    });
}

} // namespace terrain::client
