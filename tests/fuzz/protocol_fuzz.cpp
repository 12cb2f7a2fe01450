// libFuzzer target: the protocol machines themselves, as they run in the server and the client.
// Byte 0 picks the side and the start; the rest is a byte stream cut into reads (sizes and gaps
// from a generator seeded by byte 0).
// - Server side (even byte 0): the stream is what a hostile client sends to a SessionMachine on
//   a ServerHub (with a valid deformer Hello first when bit 1 is set, so that the live handlers
//   are reached), while an honest viewer follows the world over a simulated link.
//   Properties: never crash; every frame the session writes decodes, nothing follows a
//   Disconnect, and a session that closed wrote one; the honest viewer ends at the hub's
//   broadcast seq and hash, which is the authority's; the authority's world keeps every
//   invariant; the live-session count matches the sessions that are live.
// - Client side (odd byte 0): the stream is what a hostile server sends to a ClientMachine (after
//   a valid Welcome and snapshot when bit 1 is set). After a drop the machine reconnects and
//   reads on. Properties: never crash; the replica keeps every invariant; every frame the client
//   writes decodes.

#include "support/sim_net.h"

#include <terrain/procedural_map.h>
#include <terrain/server/auth_token.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/snapshot_stream.h>

#include <cstdint>
#include <cstdlib>
#include <optional>
#include <span>
#include <vector>

namespace {

namespace pb = terrain::v1;
namespace wire = terrain::wire;
namespace server = terrain::server;
namespace client = terrain::client;
using terrain::testing::SimClient;
using terrain::testing::SimWorld;

std::optional<terrain::Terrain> g_world;
std::vector<std::uint8_t> g_welcome_and_snapshot; // frames a server sends a joining client
const std::vector<std::uint8_t> kSecret(32, 7);

void check(bool ok) {
    if (!ok)
        __builtin_trap();
}

struct Reads {
    std::uint32_t rng;
    std::size_t max_read;
    std::size_t next() {
        rng ^= rng << 13;
        rng ^= rng >> 17;
        rng ^= rng << 5;
        return 1 + rng % max_read;
    }
};

/// Every frame in `bytes` decodes; returns them.
std::vector<pb::Envelope> decodeAll(const std::vector<std::uint8_t>& bytes) {
    wire::FrameReader reader(std::size_t{64} << 20);
    auto space = reader.prepare(bytes.size());
    std::copy(bytes.begin(), bytes.end(), space.begin());
    reader.commit(bytes.size());
    std::vector<pb::Envelope> out;
    for (;;) {
        auto frame = reader.next();
        check(frame.ok());
        if (!frame->has_value())
            break;
        auto envelope = wire::decodeEnvelope(**frame);
        check(envelope.ok());
        out.push_back(std::move(*envelope));
    }
    return out;
}

/// The hostile client's end: takes what the session writes, completes each write a little later.
class FuzzPeer : public server::SessionLink {
  public:
    explicit FuzzPeer(SimWorld& world) : world_(world) {}
    ~FuzzPeer() override {
        if (session)
            session->attach(nullptr);
    }
    std::shared_ptr<server::SessionMachine> session;
    std::vector<std::uint8_t> written;
    bool reading = true;
    bool closed = false;

    void framesQueued() override {
        if (writing_ || !session)
            return;
        const std::size_t n = session->beginWrite(64 << 10);
        if (n == 0)
            return;
        for (std::size_t i = 0; i < n; ++i) {
            const wire::Frame& f = session->outbound().at(i).frame;
            written.insert(written.end(), f->begin(), f->end());
        }
        writing_ = true;
        world_.at(world_.now + 0.0005, [this] {
            writing_ = false;
            if (session && !closed)
                session->endWrite(true);
        });
    }
    void setDeadline(double at) override {
        const std::uint64_t token = ++token_;
        if (at > world_.now + 1e6)
            return;
        world_.at(at, [this, token] {
            if (token == token_ && session && !closed)
                session->tick(world_.now);
        });
    }
    void stopReading() override { reading = false; }
    void closeLink() override { closed = true; }

  private:
    SimWorld& world_;
    bool writing_ = false;
    std::uint64_t token_ = 0;
};

void fuzzServerSide(std::uint8_t mode, std::span<const std::uint8_t> stream, Reads reads) {
    SimWorld world;
    server::ServerConfig config;
    config.token_secret = kSecret;
    config.outbound_budget_bytes = 16 << 10;
    config.op_log_capacity = 64;
    config.snapshot_chunk_bytes = 4096;
    server::Authority authority(*g_world, 0, config.op_log_capacity);
    server::ServerHub hub(world, config, authority, nullptr);

    client::ConnectionConfig viewer_config;
    viewer_config.token =
        server::mintToken({100, server::Role::kViewer, world.unixSeconds() + 3600}, kSecret);
    terrain::testing::LinkSpec link;
    link.latency = 0.001;
    link.bytes_per_second = 1e8;
    SimClient viewer(world, hub, viewer_config, link, "viewer");
    check(viewer.replica.loadGenesis(*g_world).ok());
    viewer.connect();

    FuzzPeer peer(world);
    peer.session = hub.addSession("fuzz", world.now, &peer);
    std::vector<std::uint8_t> input;
    if ((mode & 2) != 0) {
        pb::Envelope hello;
        hello.mutable_hello()->set_protocol_version(wire::kProtocolVersion);
        hello.mutable_hello()->set_token(
            server::mintToken({1, server::Role::kDeformer, world.unixSeconds() + 3600}, kSecret));
        wire::appendFrame(hello, input);
    }
    input.insert(input.end(), stream.begin(), stream.end());
    std::size_t pos = 0;
    while (pos < input.size()) {
        const std::size_t n = std::min(reads.next(), input.size() - pos);
        const std::span<const std::uint8_t> chunk(input.data() + pos, n);
        pos += n;
        world.runTo(world.now + static_cast<double>(reads.rng % 8) * 0.001);
        if (peer.reading && !peer.closed)
            peer.session->receive(chunk, world.now);
    }
    // long enough for the hello timeout, the close linger and every snapshot build
    world.runTo(world.now + 10.0);

    const std::vector<pb::Envelope> frames = decodeAll(peer.written);
    for (std::size_t i = 0; i + 1 < frames.size(); ++i)
        check(!frames[i].has_disconnect());
    if (peer.session->closed())
        check(!frames.empty() && frames.back().has_disconnect());
    check(hub.broadcastHash() == authority.terrain().worldHash());
    check(viewer.machine.synced());
    check(viewer.replica.seq() == hub.broadcastSeq());
    check(viewer.replica.worldHash() == hub.broadcastHash());
    check(authority.terrain().checkInvariants().ok());
    const std::uint64_t live = 1 + (peer.session->live() ? 1 : 0);
    check(hub.stats().sessions_live == live);
}

void fuzzClientSide(std::uint8_t mode, std::span<const std::uint8_t> stream, Reads reads) {
    client::ConnectionConfig config;
    config.max_frame_bytes = 1 << 20;
    config.max_snapshot_bytes = 8 << 20;
    client::Replica replica;
    client::ClientMachine machine(config, replica);
    machine.linkUp();
    std::vector<std::uint8_t> sent;
    std::vector<std::uint8_t> input;
    if ((mode & 2) != 0)
        input = g_welcome_and_snapshot;
    input.insert(input.end(), stream.begin(), stream.end());
    std::size_t pos = 0;
    std::uint64_t now_ns = 0;
    while (pos < input.size()) {
        const std::size_t n = std::min(reads.next(), input.size() - pos);
        machine.receive({input.data() + pos, n}, now_ns += 1000);
        pos += n;
        sent.insert(sent.end(), machine.output().begin(), machine.output().end());
        machine.output().clear();
        if (machine.drop()) { // a hostile server again: the machine starts over on a new link
            machine.linkDown();
            machine.linkUp();
        }
        machine.applyAllArrived();
    }
    sent.insert(sent.end(), machine.output().begin(), machine.output().end());
    decodeAll(sent);
    if (replica.ready())
        check(replica.terrain().checkInvariants().ok());
}

} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    terrain::ProceduralMapOptions o;
    o.width = 129; // two tiles
    o.height = 65;
    o.seed = 11;
    o.wavelength_metres = 24.0;
    auto t = terrain::makeProceduralMap(o);
    if (!t)
        std::abort();
    g_world.emplace(std::move(*t));
    pb::Envelope welcome;
    pb::Welcome* w = welcome.mutable_welcome();
    w->set_protocol_version(wire::kProtocolVersion);
    w->set_player_id(1);
    w->set_role("viewer");
    wire::specToWire(g_world->spec(), *w->mutable_world());
    wire::appendFrame(welcome, g_welcome_and_snapshot);
    for (const wire::Frame& f : wire::buildSnapshotFrames(*g_world, 0, 4096).frames)
        g_welcome_and_snapshot.insert(g_welcome_and_snapshot.end(), f->begin(), f->end());
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0)
        return 0;
    Reads reads{
        0x9e3779b9u ^ (std::uint32_t{data[0]} * 0x01000193u),
        std::size_t{1} << (2 + (data[0] >> 2) % 12)};
    const std::span<const std::uint8_t> stream(data + 1, size - 1);
    if ((data[0] & 1) == 0)
        fuzzServerSide(data[0], stream, reads);
    else
        fuzzClientSide(data[0], stream, reads);
    return 0;
}
