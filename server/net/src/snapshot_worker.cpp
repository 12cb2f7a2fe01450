#include "snapshot_worker.h"

#include <terrain/assert.h>

#include <utility>

namespace terrain::server {

SnapshotWorker::SnapshotWorker(asio::io_context& io, std::function<void()> before_build)
    : io_(io), before_build_(std::move(before_build)), thread_([this] { run(); }) {}

SnapshotWorker::~SnapshotWorker() {
    alive_.reset();
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_one();
    thread_.join();
}

void SnapshotWorker::build(Terrain terrain, std::uint64_t seq, std::size_t chunk_bytes, Done done) {
    TERRAIN_ASSERT(!busy_);
    busy_ = true;
    building_seq_ = seq;
    // the completion first clears busy_, on the io thread, then hands the frames over
    Done finish = [this, alive = std::weak_ptr<bool>(alive_),
                   done = std::move(done)](std::shared_ptr<const wire::SnapshotFrames> frames) {
        if (alive.expired())
            return;
        busy_ = false;
        done(std::move(frames));
    };
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        job_.emplace(Job{std::move(terrain), seq, chunk_bytes, std::move(finish)});
    }
    wake_.notify_one();
}

void SnapshotWorker::run() {
    for (;;) {
        std::optional<Job> job;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            wake_.wait(lock, [this] { return stop_ || job_.has_value(); });
            if (stop_)
                return;
            job.swap(job_);
        }
        if (before_build_)
            before_build_();
        auto frames = std::make_shared<const wire::SnapshotFrames>(
            wire::buildSnapshotFrames(job->terrain, job->seq, job->chunk_bytes));
        asio::post(io_, [done = std::move(job->done), frames = std::move(frames)]() mutable {
            done(std::move(frames));
        });
        // the terrain copy is freed here, off the io thread, with the job
    }
}

} // namespace terrain::server
