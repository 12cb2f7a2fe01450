#include <terrain/server/server_hub.h>
#include <terrain/server/session_machine.h>
#include <terrain/surface_query.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace terrain::server {
namespace pb = wire::pb;

SessionMachine::SessionMachine(ServerHub& hub, std::uint64_t id, std::string peer, double now)
    : hub_(hub), id_(id), peer_(std::move(peer)), now_(now),
      reader_(hub.config().max_inbound_frame_bytes),
      deform_limiter_(hub.config().deform_rate_per_second, hub.config().deform_burst),
      frame_limiter_(hub.config().frame_rate_per_second, hub.config().frame_burst),
      repair_limiter_(hub.config().repair_rate_per_second, hub.config().repair_burst),
      query_limiter_(hub.config().query_rate_per_second, hub.config().query_burst) {
    deadline_ = now + hub.config().hello_timeout_seconds;
}

void SessionMachine::attach(SessionLink* link) {
    link_ = link;
    if (link_ && state_ != State::kClosed) {
        link_->setDeadline(deadline_);
        if (!queue_.empty())
            link_->framesQueued();
    }
}

void SessionMachine::setDeadline(double at) {
    deadline_ = at;
    if (link_)
        link_->setDeadline(at);
}

void SessionMachine::tick(double now) {
    now_ = std::max(now_, now);
    if (now_ < deadline_) {
        if (link_) // early: wait again
            link_->setDeadline(deadline_);
        return;
    }
    if (state_ == State::kAwaitHello)
        close(pb::REASON_TIMEOUT, "no Hello within the handshake timeout");
    else if (state_ == State::kClosing)
        finish(); // the linger is over: the peer had its chance to read the Disconnect
}

void SessionMachine::linkLost() {
    // the peer left (or reset); nothing to say to it
    finish();
}

void SessionMachine::abandon() {
    state_ = State::kClosed;
    SessionLink* link = link_;
    link_ = nullptr;
    if (link)
        link->closeLink();
}

void SessionMachine::receive(std::span<const std::uint8_t> bytes, double now) {
    while (!bytes.empty() && (state_ == State::kAwaitHello || state_ == State::kLive)) {
        const std::size_t n = std::min<std::size_t>(bytes.size(), 16 << 10);
        std::span<std::uint8_t> space = reader_.prepare(n);
        std::copy_n(bytes.begin(), n, space.begin());
        received(n, now);
        bytes = bytes.subspan(n);
    }
}

void SessionMachine::received(std::size_t n, double now) {
    hub_.counters().bytes_received += n;
    if (state_ != State::kAwaitHello && state_ != State::kLive)
        return; // closing: the Disconnect is being written; the write or the linger finishes
    now_ = std::max(now_, now);
    reader_.commit(n);
    drainFrames(now_);
}

void SessionMachine::drainFrames(double now) {
    for (;;) {
        auto next = reader_.next();
        if (!next) {
            ++hub_.counters().bad_frames;
            close(
                next.error().code == ErrorCode::kOutOfRange ? pb::REASON_FRAME_TOO_LARGE
                                                            : pb::REASON_BAD_FRAME,
                next.error().message);
            return;
        }
        if (!next->has_value())
            return;
        if (!frame_limiter_.tryConsume(now)) {
            close(pb::REASON_FLOODING, "more frames per second than the session limit");
            return;
        }
        Result<pb::Envelope> envelope = wire::decodeEnvelope(**next);
        if (!envelope) {
            ++hub_.counters().bad_frames;
            close(pb::REASON_BAD_FRAME, envelope.error().message);
            return;
        }
        if (!handleFrame(*envelope, now))
            return;
    }
}

bool SessionMachine::handleFrame(const pb::Envelope& envelope, double now) {
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
        onDeform(envelope.deform(), now);
        break;
    case Body::kHeightQuery:
        onHeightQuery(envelope.height_query(), now);
        break;
    case Body::kRayQuery:
        onRayQuery(envelope.ray_query(), now);
        break;
    case Body::kRepairRequest:
        onRepairRequest(envelope.repair_request(), now);
        break;
    case Body::kSnapshotRequest:
        onSnapshotRequest(envelope.snapshot_request(), now);
        break;
    case Body::kPing: {
        pb::Envelope reply;
        reply.mutable_pong()->set_nonce(envelope.ping().nonce());
        reply.mutable_pong()->set_server_seq(hub_.broadcastSeq());
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

void SessionMachine::onHello(const pb::Hello& hello) {
    const ServerConfig& config = hub_.config();
    if (hello.protocol_version() != wire::kProtocolVersion) {
        close(
            pb::REASON_BAD_VERSION, "protocol version " + std::to_string(hello.protocol_version()) +
                                        " is not supported (this server speaks " +
                                        std::to_string(wire::kProtocolVersion) + ")");
        return;
    }
    Result<TokenClaims> claims =
        verifyToken(hello.token(), config.token_secret, hub_.unixSeconds());
    if (!claims) {
        ++hub_.counters().bad_tokens;
        close(pb::REASON_BAD_TOKEN, claims.error().message);
        return;
    }
    if (hub_.shuttingDown()) {
        close(pb::REASON_SHUTTING_DOWN, "the server is shutting down");
        return;
    }
    if (hub_.failed()) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + hub_.failure());
        return;
    }
    if (hub_.counters().sessions_live >= config.max_sessions) {
        close(
            pb::REASON_SERVER_FULL, "all " + std::to_string(config.max_sessions) +
                                        " player slots are taken; try again later");
        return;
    }
    claims_ = *claims;
    genesis_hash_ = hello.genesis_hash();
    // a join needs every accepted op committed and broadcast first, so that the snapshot holds
    // durable ops only; this session is not live yet, so that broadcast skips it
    hub_.commitPending();
    if (state_ != State::kAwaitHello)
        return;
    if (hub_.failed()) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + hub_.failure());
        return;
    }
    state_ = State::kLive;
    setDeadline(kNever);
    ++hub_.counters().sessions_live;
    join_started_ = hub_.clock();

    const std::uint64_t current = hub_.broadcastSeq();
    std::uint64_t hash_then = 0;
    // resume only when the missed ops fit well inside the budget; otherwise a snapshot is cheaper
    const bool resume = hello.has_last_seq() && hello.last_seq() <= current &&
                        hub_.tailFits(current - hello.last_seq()) &&
                        hub_.authority().log().hashAt(hello.last_seq(), hash_then) &&
                        hash_then == hello.last_hash();
    pb::Envelope welcome;
    pb::Welcome* w = welcome.mutable_welcome();
    w->set_protocol_version(wire::kProtocolVersion);
    w->set_player_id(claims_.player_id);
    w->set_role(toString(claims_.role));
    w->set_server_seq(current);
    wire::specToWire(hub_.authority().terrain().spec(), *w->mutable_world());
    w->set_resume(resume);
    w->set_max_frame_bytes(static_cast<std::uint32_t>(config.max_inbound_frame_bytes));
    w->set_deform_rate_per_second(config.deform_rate_per_second);
    w->set_genesis_hash(hub_.genesisHash());
    sendControl(welcome);
    {
        // the join's kind: a field for log queries, words for people
        const auto [how, words] = resume ? std::pair{"resume", "resumes"}
                                  : holdsGenesis()
                                      ? std::pair{"genesis_delta", "joins by genesis delta"}
                                      : std::pair{"snapshot", "joins by snapshot"};
        LogEvent e = sessionEvent("session.join");
        e.message = "player " + std::to_string(claims_.player_id) + " as " +
                    toString(claims_.role) + ", " + words + " at seq " + std::to_string(current);
        e.fields = {
            {"player", std::to_string(claims_.player_id), true},
            {"role", toString(claims_.role), false},
            {"join", how, false},
            {"seq", std::to_string(current), true}};
        hub_.log(std::move(e));
    }
    if (resume)
        sendTail(hello.last_seq());
    else
        sendSnapshotAndTail();
}

void SessionMachine::countRefusal(int reason) {
    ServerStats& s = hub_.counters();
    ++s.ops_refused;
    ++s.refused_by_reason
          [static_cast<std::size_t>(reason) < kReasonSlots ? static_cast<std::size_t>(reason) : 0];
}

void SessionMachine::onDeform(const pb::DeformRequest& request, double now) {
    pb::Envelope reply;
    pb::DeformReply* r = reply.mutable_deform_reply();
    r->set_request_id(request.request_id());
    auto refuse = [&](pb::Reason reason, const std::string& message) {
        countRefusal(reason);
        r->mutable_refused()->set_reason(reason);
        r->mutable_refused()->set_message(message);
        sendControl(reply);
    };
    if (!mayDeform(claims_.role))
        return refuse(
            pb::REASON_NOT_PERMITTED,
            "role " + std::string(toString(claims_.role)) + " may not request deformations");
    if (!deform_limiter_.tryConsume(now))
        return refuse(pb::REASON_RATE_LIMITED, "more deformations per second than the limit");
    if (hub_.failed() || hub_.shuttingDown())
        return refuse(pb::REASON_UNAVAILABLE, "the server is not accepting ops now");
    const double apply_started = hub_.clock();
    Result<Accepted> accepted = makeError(ErrorCode::kBadFormat, "deform request without an op");
    if (request.has_metres()) {
        Result<OpRequest> op = wire::requestFromWire(request.metres());
        accepted = op ? hub_.authority().apply(*op) : Result<Accepted>(op.error());
    } else if (request.has_canonical()) {
        Result<DeformOp> op = wire::opFromWire(request.canonical());
        accepted = op ? hub_.authority().apply(*op) : Result<Accepted>(op.error());
    }
    if (!accepted) {
        wire::refusalToWire(accepted.error(), *r->mutable_refused());
        countRefusal(r->refused().reason());
        sendControl(reply);
        return;
    }
    const double apply_seconds = hub_.clock() - apply_started;
    hub_.observe(HubTiming::kApply, apply_seconds);
    hub_.submit(shared_from_this(), request.request_id(), std::move(*accepted), now, apply_seconds);
}

void SessionMachine::onHeightQuery(const pb::HeightQuery& query, double now) {
    if (!query_limiter_.tryConsume(now)) {
        pb::Envelope reply;
        reply.mutable_height_reply()->set_request_id(query.request_id());
        reply.mutable_height_reply()->mutable_refused()->set_reason(pb::REASON_RATE_LIMITED);
        reply.mutable_height_reply()->mutable_refused()->set_message(
            "more height and ray queries per second than the limit");
        sendControl(reply);
        return;
    }
    const Terrain& t = hub_.authority().terrain();
    const WorldSpec& spec = t.spec();
    const double sx = static_cast<double>(spec.spacing) / spec.units_per_metre;
    const bool inside = std::isfinite(query.x()) && std::isfinite(query.y()) && query.x() >= 0 &&
                        query.y() >= 0 && query.x() <= sx * spec.cellsX() &&
                        query.y() <= sx * spec.cellsY();
    pb::Envelope reply;
    pb::HeightReply* r = reply.mutable_height_reply();
    r->set_request_id(query.request_id());
    r->set_inside(inside);
    r->set_seq(hub_.authority().seq());
    if (inside) {
        r->set_height(surfaceHeight(t, query.x(), query.y()));
        const glm::dvec3 n = surfaceNormal(t, query.x(), query.y());
        r->set_normal_x(n.x);
        r->set_normal_y(n.y);
        r->set_normal_z(n.z);
    }
    sendControl(reply);
}

void SessionMachine::onRayQuery(const pb::RayQuery& query, double now) {
    pb::Envelope reply;
    pb::RayReply* r = reply.mutable_ray_reply();
    r->set_request_id(query.request_id());
    r->set_seq(hub_.authority().seq());
    const double values[] = {query.origin_x(), query.origin_y(), query.origin_z(),    query.dir_x(),
                             query.dir_y(),    query.dir_z(),    query.max_distance()};
    const bool finite = std::all_of(
        std::begin(values), std::end(values), [](double v) { return std::isfinite(v); });
    const double max_metres = 1e7; // bounds the walk: no map is wider than 10^4 km
    if (!query_limiter_.tryConsume(now)) {
        r->mutable_refused()->set_reason(pb::REASON_RATE_LIMITED);
        r->mutable_refused()->set_message("more height and ray queries per second than the limit");
    } else if (!finite || query.max_distance() < 0 || query.max_distance() > max_metres) {
        r->mutable_refused()->set_reason(pb::REASON_OUT_OF_RANGE);
        r->mutable_refused()->set_message(
            "ray origin, direction and max_distance must be finite, 0 <= max_distance <= 1e7");
    } else {
        const std::optional<RayHit> hit = castRay(
            hub_.authority().terrain(), {query.origin_x(), query.origin_y(), query.origin_z()},
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

void SessionMachine::onRepairRequest(const pb::RepairRequest& request, double now) {
    const ServerConfig& config = hub_.config();
    if (!repair_limiter_.tryConsume(now)) {
        close(pb::REASON_RATE_LIMITED, "more repair requests per second than the limit");
        return;
    }
    if (hub_.failed()) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + hub_.failure());
        return;
    }
    if (static_cast<std::size_t>(request.tiles_size()) > config.max_repair_tiles) {
        close(
            pb::REASON_OUT_OF_RANGE, "repair asks for " + std::to_string(request.tiles_size()) +
                                         " tiles; the limit is " +
                                         std::to_string(config.max_repair_tiles));
        return;
    }
    const Terrain& t = hub_.authority().terrain();
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
    hub_.commitPending();
    if (state_ != State::kLive)
        return;
    pb::Envelope reply;
    pb::RepairState* r = reply.mutable_repair_state();
    r->set_seq(hub_.broadcastSeq());
    r->set_world_hash(t.worldHash());
    wire::TileBlob blob = wire::encodeTiles(t, tiles);
    r->set_raw_bytes(blob.raw_bytes);
    r->set_tiles(blob.compressed.data(), blob.compressed.size());
    if (request.want_tile_hashes())
        for (std::int32_t tile = 0; tile < t.spec().tileCount(); ++tile)
            r->add_tile_hashes(t.tileHash(tile));
    ++hub_.counters().repairs_served;
    sendControl(reply);
}

void SessionMachine::onSnapshotRequest(const pb::SnapshotRequest& request, double now) {
    if (!repair_limiter_.tryConsume(now)) {
        close(pb::REASON_RATE_LIMITED, "more snapshot requests per second than the limit");
        return;
    }
    if (hub_.failed()) {
        close(pb::REASON_UNAVAILABLE, "the server's journal failed: " + hub_.failure());
        return;
    }
    hub_.commitPending();
    if (state_ != State::kLive || hub_.failed())
        return;
    if (awaiting_snapshot_ && request.genesis_hash() != genesis_hash_) {
        // the kind asked for changed (a delta this client could not decode): ask again
        awaiting_snapshot_ = false;
    }
    genesis_hash_ = request.genesis_hash();
    sendSnapshotAndTail();
}

void SessionMachine::onHealthRequest() {
    pb::Envelope reply;
    pb::HealthReply* r = reply.mutable_health_reply();
    r->set_healthy(!hub_.failed() && !hub_.shuttingDown());
    // one state: ops accepted but not yet committed are applied to the authority's terrain,
    // and must not show in the hash until their seq does
    r->set_seq(hub_.broadcastSeq());
    r->set_world_hash(hub_.broadcastHash());
    r->set_sessions(static_cast<std::uint32_t>(hub_.sessionCount()));
    r->set_detail(
        hub_.failed()         ? hub_.failure()
        : hub_.shuttingDown() ? "shutting down"
                              : "serving");
    sendControl(reply);
}

bool SessionMachine::holdsGenesis() const {
    return genesis_hash_ != 0 && genesis_hash_ == hub_.genesisHash();
}

void SessionMachine::sendSnapshotAndTail() {
    const ServerHub::SnapshotKind kind =
        holdsGenesis() ? ServerHub::kGenesisDelta : ServerHub::kWholeSnapshot;
    if (const wire::SnapshotFrames* snapshot = hub_.usableSnapshot(kind)) {
        deliverSnapshot(*snapshot);
        return;
    }
    if (awaiting_snapshot_)
        return; // already asked
    awaiting_snapshot_ = true;
    hub_.awaitSnapshot(shared_from_this(), kind);
}

void SessionMachine::deliverSnapshot(const wire::SnapshotFrames& snapshot) {
    awaiting_snapshot_ = false;
    if (snapshot.genesis_hash != 0)
        ++hub_.counters().genesis_deltas_sent;
    else
        ++hub_.counters().snapshots_sent;
    for (const wire::Frame& frame : snapshot.frames)
        enqueue(frame, FrameClass::kSnapshot);
    sent_through_ = snapshot.seq;
    sendTail(snapshot.seq);
}

void SessionMachine::sendTail(std::uint64_t after_seq) {
    if (join_started_ >= 0.0) { // the join's frames are queued now: its server-side time
        hub_.observe(HubTiming::kJoin, hub_.clock() - join_started_);
        join_started_ = -1.0;
    }
    sent_through_ = after_seq;
    // note: inside a broadcast loop the snapshot may be ahead of broadcastSeq(); then there is
    // no tail and the loop's later ops are skipped by sendOp (seq <= sent_through_)
    for (std::uint64_t seq = after_seq + 1; seq <= hub_.broadcastSeq(); ++seq)
        sendOp(seq, hub_.opFrame(seq));
}

void SessionMachine::sendOp(std::uint64_t seq, const wire::Frame& frame) {
    if (state_ != State::kLive || awaiting_snapshot_ || seq <= sent_through_)
        return;
    if (queue_.budgetBytes() + frame->size() > hub_.config().outbound_budget_bytes) {
        overBudget();
        return;
    }
    enqueue(frame, FrameClass::kOp);
    sent_through_ = seq;
}

void SessionMachine::sendOps(std::uint64_t first, std::uint64_t last, const wire::Frame& batch) {
    if (state_ != State::kLive || awaiting_snapshot_ || last <= sent_through_)
        return;
    if (first <= sent_through_) {
        for (std::uint64_t seq = sent_through_ + 1; seq <= last; ++seq)
            sendOp(seq, hub_.opFrame(seq));
        return;
    }
    if (queue_.budgetBytes() + batch->size() > hub_.config().outbound_budget_bytes) {
        overBudget();
        return;
    }
    enqueue(batch, FrameClass::kOp);
    sent_through_ = last;
}

void SessionMachine::overBudget() {
    if (resynced_since_drain_) {
        ++hub_.counters().slow_disconnects;
        close(
            pb::REASON_SLOW_CONSUMER, "outbound queue over " +
                                          std::to_string(hub_.config().outbound_budget_bytes) +
                                          " bytes again before the last resync was read");
        return;
    }
    // drop the backlog this client has not started to receive; a snapshot replaces it
    queue_.dropResyncable(in_flight_);
    resynced_since_drain_ = true;
    ++hub_.counters().resyncs;
    sendSnapshotAndTail();
}

void SessionMachine::sendControl(const pb::Envelope& envelope) {
    if (state_ == State::kClosing || state_ == State::kClosed)
        return;
    // replies cannot be replaced by a snapshot: a peer that asks but does not read is cut off
    // once its backlog is over budget (one reply may take it over, never two)
    if (queue_.budgetBytes() > hub_.config().outbound_budget_bytes) {
        ++hub_.counters().slow_disconnects;
        close(
            pb::REASON_SLOW_CONSUMER, "replies queued over " +
                                          std::to_string(hub_.config().outbound_budget_bytes) +
                                          " bytes: the client does not read them");
        return;
    }
    enqueue(wire::encodeFrame(envelope), FrameClass::kControl);
}

void SessionMachine::enqueue(wire::Frame frame, FrameClass cls) {
    hub_.counters().bytes_queued += frame->size();
    queue_.push(std::move(frame), cls);
    if (link_ && !writing_)
        link_->framesQueued();
}

std::size_t SessionMachine::beginWrite(std::size_t max_bytes) {
    if (writing_ || state_ == State::kClosed || queue_.empty())
        return 0;
    std::size_t bytes = 0;
    in_flight_ = 0;
    while (in_flight_ < queue_.size() && (in_flight_ == 0 || bytes < max_bytes)) {
        bytes += queue_.at(in_flight_).frame->size();
        ++in_flight_;
    }
    writing_ = true;
    return in_flight_;
}

void SessionMachine::endWrite(bool ok) {
    if (!writing_)
        return;
    writing_ = false;
    queue_.popFront(in_flight_);
    in_flight_ = 0;
    if (!ok) {
        finish();
        return;
    }
    // a client that has read its resync snapshot and keeps up may be resynced again later
    // note: snapshot frames are not in budgetBytes(), so "no snapshot left" is checked too
    if (queue_.totalBytes() == queue_.budgetBytes() &&
        queue_.budgetBytes() < hub_.config().outbound_budget_bytes / 4)
        resynced_since_drain_ = false;
    if (queue_.empty()) {
        resynced_since_drain_ = false;
        if (state_ == State::kClosing)
            finish();
        return;
    }
    if (link_)
        link_->framesQueued();
}

void SessionMachine::close(pb::Reason reason, const std::string& message) {
    if (state_ == State::kClosing || state_ == State::kClosed)
        return;
    {
        LogEvent e = sessionEvent("session.close");
        e.message = "closing: " + wire::describe(reason, message);
        e.fields = {{"reason", pb::Reason_Name(reason), false}};
        hub_.log(std::move(e));
    }
    pb::Envelope bye;
    bye.mutable_disconnect()->set_reason(reason);
    bye.mutable_disconnect()->set_message(message);
    // the goodbye goes out after what is being written; queued ops are no longer needed
    queue_.dropResyncable(in_flight_);
    if (state_ == State::kLive)
        --hub_.counters().sessions_live;
    state_ = State::kClosing;
    if (link_)
        link_->stopReading();
    setDeadline(now_ + hub_.config().close_linger_seconds);
    enqueue(wire::encodeFrame(bye), FrameClass::kControl);
}

LogEvent SessionMachine::sessionEvent(std::string name) const {
    LogEvent e;
    e.event = std::move(name);
    e.session = id_;
    e.peer = peer_;
    return e;
}

void SessionMachine::finish() {
    if (state_ == State::kClosed)
        return;
    if (state_ == State::kLive)
        --hub_.counters().sessions_live;
    state_ = State::kClosed;
    deadline_ = kNever;
    SessionLink* link = link_;
    link_ = nullptr;
    if (link)
        link->closeLink();
    hub_.remove(this);
}

} // namespace terrain::server
