#pragma once

// The game client's implementation (internal: the C ABI, terrain_client.h, is its only user and
// the public C++ class wraps that ABI). Its contract is the public header's
// (terrain/game/client.h).

#include <terrain/game/client.h>

namespace terrain::game::detail {

class Session {
  public:
    /// Indices per dirty page.
    static const std::uint32_t kIndicesPerPage;

    explicit Session(ClientOptions options);
    /// Closes (joins the worker thread).
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    /// Starts connecting (returns at once). kBadParameter for options that break a rule (no
    /// host, port 0, no token, tau or cap out of range); kClosed after close().
    ClientResult connect();
    /// Pumps until the world is loaded and synced, up to `timeout_seconds`: kTimedOut, or the
    /// reason the client closed (a bad token: kRefusedByServer).
    ClientResult waitSynced(double timeout_seconds);
    /// Once a frame: reads the network and applies this frame's share of the ops (a burst is
    /// spread over frames). kClosed once closed (lastError() says why).
    ClientResult pump();
    /// Closes the link for good and stops the worker. Later calls answer kClosed.
    void close();

    /// A deformation centred at (x, y) metres of `radius` metres (a crater's footprint, rim
    /// included, is twice that): `height` and `strength` (in [0, 1]) as OpKind says. Refused at
    /// once, nothing sent: kNotConnected, kNotSynced, kBadParameter (the rule broken), kClosed.
    /// Sent: the id its answer (takeAnswers()) will carry; the server may still refuse it.
    ClientResult
    requestOp(OpKind kind, double x, double y, double radius, double height, double strength = 1.0);
    /// A crater `depth` metres deep with a rim `rim_ratio * depth` high (0.375 puts the cavity's
    /// volume back as ejecta).
    ClientResult
    requestCrater(double x, double y, double radius, double depth, double rim_ratio = 0.3) {
        return requestOp(OpKind::kCrater, x, y, radius, depth, rim_ratio);
    }
    /// The server's answers that arrived since the last call.
    std::vector<OpAnswer> takeAnswers();

    WorldState world() const;
    /// The last error (a refusal, a lost link, a give up); "" if none yet.
    const std::string& lastError() const;
    /// A call failed with this message: lastError() says it until something newer happens.
    void noteError(std::string message);
    /// The ground height at (x, y) metres in the replica (exact, not the mesh); false off the
    /// map or before the world is loaded.
    bool heightAt(double x, double y, double& height_out) const;

    /// The camera in, the newest finished tiles out: hands the camera to the worker (which
    /// tessellates the newest one it has) and takes its newest finished tiles. Returns whether
    /// any tile changed. kNotSynced before the world is loaded (nothing to draw yet).
    ClientResult tessellate(const Camera& camera, bool* changed = nullptr);
    /// Frames the tiles are behind the newest camera (0: the worker keeps up).
    std::uint64_t meshLag() const;
    /// The tessellation's error bound for the tiles held, at their camera (pixels).
    double meshErrorPixels() const;

    /// Tiles (0 before the first tessellate() with a world).
    std::int32_t tileCount() const;
    /// A tile's buffers and changes; kBadParameter for a tile out of range.
    ClientResult tile(std::int32_t tile, TileBuffers& out) const;
    /// Whether the tile changed since markUploaded(tile).
    bool tileChanged(std::int32_t tile) const;
    /// The game uploaded the tile's changes: they are forgotten.
    void markUploaded(std::int32_t tile);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace terrain::game::detail
