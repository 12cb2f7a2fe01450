#include "session.h"

#include <terrain/server/server.h>
#include <terrain/surface_query.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace terrain::server {
namespace pb = wire::pb;

namespace {

// frames are gathered into one write up to this many bytes
constexpr std::size_t kMaxGatherBytes = 256 << 10;
constexpr std::size_t kReadChunk = 16 << 10;

std::int64_t unixNow() {
    return std::chrono::duration_cast<std::chrono::seconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

} // namespace

Session::Session(Server& server, asio::ip::tcp::socket socket, std::uint64_t id)
    : server_(server), socket_(std::move(socket)), id_(id),
      reader_(server.config_.max_inbound_frame_bytes),
      deform_limiter_(server.config_.deform_rate_per_second, server.config_.deform_burst),
      frame_limiter_(server.config_.frame_rate_per_second, server.config_.frame_burst),
      repair_limiter_(server.config_.repair_rate_per_second, server.config_.repair_burst),
      query_limiter_(server.config_.query_rate_per_second, server.config_.query_burst),
      timer_(socket_.get_executor()) {
    asio::error_code ec;
    const auto endpoint = socket_.remote_endpoint(ec);
    peer_ = ec ? "?" : endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
}

double Session::now() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

void Session::start() {
    asio::error_code ignored;
    socket_.set_option(asio::ip::tcp::no_delay(true), ignored);
    if (server_.config_.socket_send_buffer_bytes > 0)
        socket_.set_option(
            asio::socket_base::send_buffer_size(server_.config_.socket_send_buffer_bytes), ignored);
    timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(server_.config_.hello_timeout_seconds)));
    timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
        if (!ec && self->state_ == State::kAwaitHello)
            self->close(pb::REASON_TIMEOUT, "no Hello within the handshake timeout");
    });
    readMore();
}

void Session::readMore() {
    if (state_ == State::kClosing || state_ == State::kClosed)
        return;
    std::span<std::uint8_t> space = reader_.prepare(kReadChunk);
    socket_.async_read_some(
        asio::buffer(space.data(), space.size()),
        [self = shared_from_this()](const asio::error_code& ec, std::size_t n) {
            self->onRead(ec, n);
        });
}

void Session::onRead(const asio::error_code& ec, std::size_t n) {
    if (state_ == State::kClosed)
        return;
    if (state_ == State::kClosing)
        return; // the Disconnect is being written; the write or the linger timer finishes
    if (ec) {
        // the peer left (or reset); nothing to say to it
        finish();
        return;
    }
    reader_.commit(n);
    for (;;) {
        auto next = reader_.next();
        if (!next) {
            ++server_.stats_.bad_frames;
            close(
                next.error().code == ErrorCode::kOutOfRange ? pb::REASON_FRAME_TOO_LARGE
                                                            : pb::REASON_BAD_FRAME,
                next.error().message);
            return;
        }
        if (!next->has_value())
            break;
        if (!frame_limiter_.tryConsume(now())) {
            close(pb::REASON_FLOODING, "more frames per second than the session limit");
            return;
        }
        Result<pb::Envelope> envelope = wire::decodeEnvelope(**next);
        if (!envelope) {
            ++server_.stats_.bad_frames;
            close(pb::REASON_BAD_FRAME, envelope.error().message);
            return;
        }
        if (!handleFrame(*envelope))
            return;
    }
    readMore();
}

bool Session::handleFrame(const pb::Envelope& envelope) {
    using Body = pb::Envelope::BodyCase;
    if (state_ == State::kAwaitHello) {
        if (envelope.body_case() == Body::kHello) {
            onHello(envelope.hello());
        } else if (envelope.body_case() == Body::kHealthRequest) {
            onHealthRequest();
        } else {
            close(pb::REASON_PROTOCOL, "the first frame must be Hello (or HealthRequest)");
        }
        return state_ == State::kLive || state_ == State::kAwaitHello;
    }
    switch (envelope.body_case()) {
    case Body::kDeform:
        onDeform(envelope.deform());
        break;
    case Body::kHeightQuery:
        onHeightQuery(envelope.height_query());
        break;
    case Body::kRayQuery:
        onRayQuery(envelope.ray_query());
        break;
    case Body::kRepairRequest:
        onRepairRequest(envelope.repair_request());
        break;
    case Body::kSnapshotRequest:
        onSnapshotRequest(envelope.snapshot_request());
        break;
    case Body::kPing: {
        pb::Envelope reply;
        reply.mutable_pong()->set_nonce(envelope.ping().nonce());
        reply.mutable_pong()->set_server_seq(server_.broadcast_seq_);
        sendControl(reply);
        break;
    }
    case Body::kHealthRequest:
        onHealthRequest();
        break;
    default:
        close(
            pb::REASON_PROTOCOL,
            "a client may not send " +
                std::string(
                    pb::Envelope::descriptor()->FindFieldByNumber(envelope.body_case())->name()));
        return false;
    }
    return state_ == State::kLive;
}

void Session::onHello(const pb::Hello& hello) {
    if (hello.protocol_version() != wire::kProtocolVersion) {
        close(
            pb::REASON_BAD_VERSION, "protocol version " + std::to_string(hello.protocol_version()) +
                                        " is not supported (this server speaks " +
                                        std::to_string(wire::kProtocolVersion) + ")");
        return;
    }
    Result<TokenClaims> claims =
        verifyToken(hello.token(), server_.config_.token_secret, unixNow());
    if (!claims) {
        ++server_.stats_.bad_tokens;
        close(pb::REASON_BAD_TOKEN, claims.error().message);
        return;
    }
    if (server_.shutting_down_) {
        close(pb::REASON_SHUTTING_DOWN, "the server is shutting down");
        return;
    }
    if (server_.failed_) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + server_.failure_);
        return;
    }
    claims_ = *claims;
    genesis_hash_ = hello.genesis_hash();
    // a join needs every accepted op committed and broadcast first, so that the snapshot holds
    // durable ops only; this session is not live yet, so that broadcast skips it
    server_.commitPending();
    if (state_ != State::kAwaitHello)
        return;
    if (server_.failed_) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + server_.failure_);
        return;
    }
    state_ = State::kLive;
    timer_.cancel();
    ++server_.stats_.sessions_live;

    const std::uint64_t current = server_.broadcast_seq_;
    std::uint64_t hash_then = 0;
    // resume only when the missed ops fit well inside the budget; otherwise a snapshot is cheaper
    const bool resume = hello.has_last_seq() && hello.last_seq() <= current &&
                        server_.tailFits(current - hello.last_seq()) &&
                        server_.authority_.log().hashAt(hello.last_seq(), hash_then) &&
                        hash_then == hello.last_hash();
    pb::Envelope welcome;
    pb::Welcome* w = welcome.mutable_welcome();
    w->set_protocol_version(wire::kProtocolVersion);
    w->set_player_id(claims_.player_id);
    w->set_role(toString(claims_.role));
    w->set_server_seq(current);
    wire::specToWire(server_.authority_.terrain().spec(), *w->mutable_world());
    w->set_resume(resume);
    w->set_max_frame_bytes(static_cast<std::uint32_t>(server_.config_.max_inbound_frame_bytes));
    w->set_deform_rate_per_second(server_.config_.deform_rate_per_second);
    w->set_genesis_hash(server_.genesis_hash_);
    sendControl(welcome);
    std::printf(
        "session %llu (%s): player %llu as %s, %s at seq %llu\n",
        static_cast<unsigned long long>(id_), peer_.c_str(),
        static_cast<unsigned long long>(claims_.player_id), toString(claims_.role),
        resume           ? "resumes"
        : holdsGenesis() ? "joins by genesis delta"
                         : "joins by snapshot",
        static_cast<unsigned long long>(current));
    if (resume)
        sendTail(hello.last_seq());
    else
        sendSnapshotAndTail();
}

void Session::onDeform(const pb::DeformRequest& request) {
    pb::Envelope reply;
    pb::DeformReply* r = reply.mutable_deform_reply();
    r->set_request_id(request.request_id());
    auto refuse = [&](pb::Reason reason, const std::string& message) {
        ++server_.stats_.ops_refused;
        r->mutable_refused()->set_reason(reason);
        r->mutable_refused()->set_message(message);
        sendControl(reply);
    };
    if (!mayDeform(claims_.role))
        return refuse(
            pb::REASON_NOT_PERMITTED,
            "role " + std::string(toString(claims_.role)) + " may not request deformations");
    if (!deform_limiter_.tryConsume(now()))
        return refuse(pb::REASON_RATE_LIMITED, "more deformations per second than the limit");
    if (server_.failed_ || server_.shutting_down_)
        return refuse(pb::REASON_UNAVAILABLE, "the server is not accepting ops now");
    Result<Accepted> accepted = makeError(ErrorCode::kBadFormat, "deform request without an op");
    if (request.has_metres()) {
        Result<OpRequest> op = wire::requestFromWire(request.metres());
        accepted = op ? server_.authority_.apply(*op) : Result<Accepted>(op.error());
    } else if (request.has_canonical()) {
        Result<DeformOp> op = wire::opFromWire(request.canonical());
        accepted = op ? server_.authority_.apply(*op) : Result<Accepted>(op.error());
    }
    if (!accepted) {
        ++server_.stats_.ops_refused;
        wire::refusalToWire(accepted.error(), *r->mutable_refused());
        sendControl(reply);
        return;
    }
    server_.submit(shared_from_this(), request.request_id(), std::move(accepted));
}

void Session::onHeightQuery(const pb::HeightQuery& query) {
    if (!query_limiter_.tryConsume(now())) {
        pb::Envelope reply;
        reply.mutable_height_reply()->set_request_id(query.request_id());
        reply.mutable_height_reply()->mutable_refused()->set_reason(pb::REASON_RATE_LIMITED);
        reply.mutable_height_reply()->mutable_refused()->set_message(
            "more height and ray queries per second than the limit");
        sendControl(reply);
        return;
    }
    const Terrain& t = server_.authority_.terrain();
    const WorldSpec& spec = t.spec();
    const double sx = static_cast<double>(spec.spacing) / spec.units_per_metre;
    const bool inside = std::isfinite(query.x()) && std::isfinite(query.y()) && query.x() >= 0 &&
                        query.y() >= 0 && query.x() <= sx * spec.cellsX() &&
                        query.y() <= sx * spec.cellsY();
    pb::Envelope reply;
    pb::HeightReply* r = reply.mutable_height_reply();
    r->set_request_id(query.request_id());
    r->set_inside(inside);
    r->set_seq(server_.authority_.seq());
    if (inside) {
        r->set_height(surfaceHeight(t, query.x(), query.y()));
        const glm::dvec3 n = surfaceNormal(t, query.x(), query.y());
        r->set_normal_x(n.x);
        r->set_normal_y(n.y);
        r->set_normal_z(n.z);
    }
    sendControl(reply);
}

void Session::onRayQuery(const pb::RayQuery& query) {
    pb::Envelope reply;
    pb::RayReply* r = reply.mutable_ray_reply();
    r->set_request_id(query.request_id());
    r->set_seq(server_.authority_.seq());
    const double values[] = {query.origin_x(), query.origin_y(), query.origin_z(),    query.dir_x(),
                             query.dir_y(),    query.dir_z(),    query.max_distance()};
    const bool finite = std::all_of(
        std::begin(values), std::end(values), [](double v) { return std::isfinite(v); });
    const double max_metres = 1e7; // bounds the walk: no map is wider than 10^4 km
    if (!query_limiter_.tryConsume(now())) {
        r->mutable_refused()->set_reason(pb::REASON_RATE_LIMITED);
        r->mutable_refused()->set_message("more height and ray queries per second than the limit");
    } else if (!finite || query.max_distance() < 0 || query.max_distance() > max_metres) {
        r->mutable_refused()->set_reason(pb::REASON_OUT_OF_RANGE);
        r->mutable_refused()->set_message(
            "ray origin, direction and max_distance must be finite, 0 <= max_distance <= 1e7");
    } else {
        const std::optional<RayHit> hit = castRay(
            server_.authority_.terrain(), {query.origin_x(), query.origin_y(), query.origin_z()},
            {query.dir_x(), query.dir_y(), query.dir_z()}, query.max_distance());
        r->set_hit(hit.has_value());
        if (hit) {
            r->set_x(hit->point.x);
            r->set_y(hit->point.y);
            r->set_z(hit->point.z);
            r->set_distance(hit->distance);
        }
    }
    sendControl(reply);
}

void Session::onRepairRequest(const pb::RepairRequest& request) {
    if (!repair_limiter_.tryConsume(now())) {
        close(pb::REASON_RATE_LIMITED, "more repair requests per second than the limit");
        return;
    }
    if (server_.failed_) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + server_.failure_);
        return;
    }
    if (static_cast<std::size_t>(request.tiles_size()) > server_.config_.max_repair_tiles) {
        close(
            pb::REASON_OUT_OF_RANGE, "repair asks for " + std::to_string(request.tiles_size()) +
                                         " tiles; the limit is " +
                                         std::to_string(server_.config_.max_repair_tiles));
        return;
    }
    const Terrain& t = server_.authority_.terrain();
    const auto tile_count = static_cast<std::uint32_t>(t.spec().tileCount());
    std::vector<std::int32_t> tiles;
    for (std::uint32_t tile : request.tiles()) {
        if (tile >= tile_count) {
            close(
                pb::REASON_OUT_OF_RANGE, "repair asks for tile " + std::to_string(tile) +
                                             " of a map with " + std::to_string(tile_count));
            return;
        }
        tiles.push_back(static_cast<std::int32_t>(tile));
    }
    std::sort(tiles.begin(), tiles.end());
    tiles.erase(std::unique(tiles.begin(), tiles.end()), tiles.end());
    // tile state must be at the seq this session has been sent: broadcast everything first
    server_.commitPending();
    if (state_ != State::kLive)
        return;
    pb::Envelope reply;
    pb::RepairState* r = reply.mutable_repair_state();
    r->set_seq(server_.broadcast_seq_);
    r->set_world_hash(t.worldHash());
    wire::TileBlob blob = wire::encodeTiles(t, tiles);
    r->set_raw_bytes(blob.raw_bytes);
    r->set_tiles(blob.compressed.data(), blob.compressed.size());
    if (request.want_tile_hashes())
        for (std::int32_t tile = 0; tile < t.spec().tileCount(); ++tile)
            r->add_tile_hashes(t.tileHash(tile));
    ++server_.stats_.repairs_served;
    sendControl(reply);
}

void Session::onSnapshotRequest(const pb::SnapshotRequest& request) {
    if (!repair_limiter_.tryConsume(now())) {
        close(pb::REASON_RATE_LIMITED, "more snapshot requests per second than the limit");
        return;
    }
    if (server_.failed_) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + server_.failure_);
        return;
    }
    server_.commitPending();
    if (state_ != State::kLive || server_.failed_)
        return;
    if (awaiting_snapshot_ && request.genesis_hash() != genesis_hash_) {
        // the kind asked for changed (a delta this client could not decode): ask again
        awaiting_snapshot_ = false;
    }
    genesis_hash_ = request.genesis_hash();
    sendSnapshotAndTail();
}

void Session::onHealthRequest() {
    pb::Envelope reply;
    pb::HealthReply* r = reply.mutable_health_reply();
    r->set_healthy(!server_.failed_ && !server_.shutting_down_);
    // one state: ops accepted but not yet committed are applied to the authority's terrain,
    // and must not show in the hash until their seq does
    r->set_seq(server_.broadcast_seq_);
    r->set_world_hash(server_.broadcast_hash_);
    r->set_sessions(static_cast<std::uint32_t>(server_.sessions_.size()));
    r->set_detail(
        server_.failed_          ? server_.failure_
        : server_.shutting_down_ ? "shutting down"
                                 : "serving");
    sendControl(reply);
}

bool Session::holdsGenesis() const {
    return genesis_hash_ != 0 && genesis_hash_ == server_.genesis_hash_;
}

void Session::sendSnapshotAndTail() {
    const Server::SnapshotKind kind =
        holdsGenesis() ? Server::kGenesisDelta : Server::kWholeSnapshot;
    if (const wire::SnapshotFrames* snapshot = server_.usableSnapshot(kind)) {
        deliverSnapshot(*snapshot);
        return;
    }
    if (awaiting_snapshot_)
        return; // already asked
    awaiting_snapshot_ = true;
    server_.awaitSnapshot(shared_from_this(), kind);
}

void Session::deliverSnapshot(const wire::SnapshotFrames& snapshot) {
    awaiting_snapshot_ = false;
    if (snapshot.genesis_hash != 0)
        ++server_.stats_.genesis_deltas_sent;
    else
        ++server_.stats_.snapshots_sent;
    for (const wire::Frame& frame : snapshot.frames)
        enqueue(frame, FrameClass::kSnapshot);
    sent_through_ = snapshot.seq;
    sendTail(snapshot.seq);
}

void Session::sendTail(std::uint64_t after_seq) {
    sent_through_ = after_seq;
    // note: inside a broadcast loop the snapshot may be ahead of broadcast_seq_; then there is
    // no tail and the loop's later ops are skipped by sendOp (seq <= sent_through_)
    for (std::uint64_t seq = after_seq + 1; seq <= server_.broadcast_seq_; ++seq)
        sendOp(seq, server_.opFrame(seq));
}

void Session::sendOp(std::uint64_t seq, const wire::Frame& frame) {
    if (state_ != State::kLive || awaiting_snapshot_ || seq <= sent_through_)
        return;
    if (queue_.budgetBytes() + frame->size() > server_.config_.outbound_budget_bytes) {
        overBudget();
        return;
    }
    enqueue(frame, FrameClass::kOp);
    sent_through_ = seq;
}

void Session::sendOps(std::uint64_t first, std::uint64_t last, const wire::Frame& batch) {
    if (state_ != State::kLive || awaiting_snapshot_ || last <= sent_through_)
        return;
    if (first <= sent_through_) {
        for (std::uint64_t seq = sent_through_ + 1; seq <= last; ++seq)
            sendOp(seq, server_.opFrame(seq));
        return;
    }
    if (queue_.budgetBytes() + batch->size() > server_.config_.outbound_budget_bytes) {
        overBudget();
        return;
    }
    enqueue(batch, FrameClass::kOp);
    sent_through_ = last;
}

void Session::overBudget() {
    if (resynced_since_drain_) {
        ++server_.stats_.slow_disconnects;
        close(
            pb::REASON_SLOW_CONSUMER, "outbound queue over " +
                                          std::to_string(server_.config_.outbound_budget_bytes) +
                                          " bytes again before the last resync was read");
        return;
    }
    // drop the backlog this client has not started to receive; a snapshot replaces it
    queue_.dropResyncable(in_flight_);
    resynced_since_drain_ = true;
    ++server_.stats_.resyncs;
    sendSnapshotAndTail();
}

void Session::sendControl(const pb::Envelope& envelope) {
    if (state_ == State::kClosing || state_ == State::kClosed)
        return;
    // replies cannot be replaced by a snapshot: a peer that asks but does not read is cut off
    // once its backlog is over budget (one reply may take it over, never two)
    if (queue_.budgetBytes() > server_.config_.outbound_budget_bytes) {
        ++server_.stats_.slow_disconnects;
        close(
            pb::REASON_SLOW_CONSUMER, "replies queued over " +
                                          std::to_string(server_.config_.outbound_budget_bytes) +
                                          " bytes: the client does not read them");
        return;
    }
    enqueue(wire::encodeFrame(envelope), FrameClass::kControl);
}

void Session::enqueue(wire::Frame frame, FrameClass cls) {
    server_.stats_.bytes_queued += frame->size();
    queue_.push(std::move(frame), cls);
    writeMore();
}

void Session::writeMore() {
    if (writing_ || state_ == State::kClosed)
        return;
    if (queue_.empty()) {
        resynced_since_drain_ = false;
        if (state_ == State::kClosing)
            finish();
        return;
    }
    gather_.clear();
    std::size_t bytes = 0;
    in_flight_ = 0;
    while (in_flight_ < queue_.size() && (in_flight_ == 0 || bytes < kMaxGatherBytes)) {
        const wire::Frame& f = queue_.at(in_flight_).frame;
        gather_.emplace_back(f->data(), f->size());
        bytes += f->size();
        ++in_flight_;
    }
    writing_ = true;
    asio::async_write(
        socket_, gather_, [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
            self->writing_ = false;
            self->queue_.popFront(self->in_flight_);
            self->in_flight_ = 0;
            if (ec) {
                self->finish();
                return;
            }
            // a client that has read its resync snapshot and keeps up may be resynced again later
            // note: snapshot frames are not in budgetBytes(), so "no snapshot left" is checked too
            if (self->queue_.totalBytes() == self->queue_.budgetBytes() &&
                self->queue_.budgetBytes() < self->server_.config_.outbound_budget_bytes / 4)
                self->resynced_since_drain_ = false;
            self->writeMore();
        });
}

void Session::close(pb::Reason reason, const std::string& message) {
    if (state_ == State::kClosing || state_ == State::kClosed)
        return;
    std::printf(
        "session %llu (%s): closing: %s\n", static_cast<unsigned long long>(id_), peer_.c_str(),
        wire::describe(reason, message).c_str());
    pb::Envelope bye;
    bye.mutable_disconnect()->set_reason(reason);
    bye.mutable_disconnect()->set_message(message);
    // the goodbye goes out after what is being written; queued ops are no longer needed
    queue_.dropResyncable(in_flight_);
    enqueue(wire::encodeFrame(bye), FrameClass::kControl);
    if (state_ == State::kLive)
        --server_.stats_.sessions_live;
    state_ = State::kClosing;
    asio::error_code ignored;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_receive, ignored);
    timer_.cancel();
    timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(server_.config_.close_linger_seconds)));
    timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
        if (!ec)
            self->finish();
    });
    writeMore();
}

void Session::finish() {
    if (state_ == State::kClosed)
        return;
    if (state_ == State::kLive)
        --server_.stats_.sessions_live;
    state_ = State::kClosed;
    asio::error_code ignored;
    timer_.cancel();
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
    server_.remove(this);
}

} // namespace terrain::server
