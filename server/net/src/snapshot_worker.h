#pragma once

// Builds join snapshots (encode, compress, chunk: tens to hundreds of milliseconds on a grown
// world) on a thread of its own, so that a join never stalls the io thread that carries every
// other session's ops. The io thread hands over a copy of the terrain (a memory copy, far cheaper
// than the encoding) and gets the frames back as a handler posted to its io_context.
// One build at a time. Private to terrain_server_net.

#include <terrain/terrain.h>
#include <terrain/wire/snapshot_stream.h>

#include <asio.hpp>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

namespace terrain::server {

class SnapshotWorker {
  public:
    using Done = std::function<void(std::shared_ptr<const wire::SnapshotFrames>)>;

    /// `before_build` (may be empty) runs on the worker's thread before each build (tests).
    SnapshotWorker(asio::io_context& io, std::function<void()> before_build);
    /// Stops the thread (after the build in progress, if any); completions not yet run are
    /// dropped.
    ~SnapshotWorker();
    SnapshotWorker(const SnapshotWorker&) = delete;
    SnapshotWorker& operator=(const SnapshotWorker&) = delete;

    /// Io thread: whether a build was started and its completion has not run yet.
    bool busy() const { return busy_; }
    /// Seq of the build in progress (meaningful while busy()).
    std::uint64_t buildingSeq() const { return building_seq_; }
    /// Io thread, not busy(): builds the frames of `terrain` at `seq` and calls `done` on the
    /// io thread with them.
    void build(Terrain terrain, std::uint64_t seq, std::size_t chunk_bytes, Done done);

  private:
    struct Job {
        Terrain terrain;
        std::uint64_t seq = 0;
        std::size_t chunk_bytes = 0;
        Done done;
    };
    void run();

    asio::io_context& io_;
    std::function<void()> before_build_;
    /// Io thread only: completions hold a weak reference and do nothing once it is gone.
    std::shared_ptr<bool> alive_ = std::make_shared<bool>(true);
    bool busy_ = false;
    std::uint64_t building_seq_ = 0;
    std::mutex mutex_;
    std::condition_variable wake_;
    std::optional<Job> job_; ///< guarded by mutex_
    bool stop_ = false;      ///< guarded by mutex_
    std::thread thread_;
};

} // namespace terrain::server
