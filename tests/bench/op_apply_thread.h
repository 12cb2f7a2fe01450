#pragma once

// The client's network thread, as client_battle_bench --apply-thread stands it in: a replica on a
// thread of its own applies every op as it arrives and checks its hash; the frame's replica
// follows it by the tiles each op changed (ReplicaSync), applying nothing, as the library's
// network thread (client/api/src/network_thread.cpp) and the game's frame do. No sockets: the
// ops are handed over in memory, so what is measured is the frame's side of that design.

#include <terrain/client/replica.h>
#include <terrain/client/replica_sync.h>
#include <terrain/deform_op.h>

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace terrain::bench {

class OpApplyThread {
  public:
    struct Arrival {
        std::uint64_t seq = 0;
        DeformOp op{};
        std::uint64_t world_hash = 0;
    };

    /// Starts from a copy of `frame`'s world (its tiles' versions too: the first sync brings
    /// only what the ops change).
    explicit OpApplyThread(const client::Replica& frame) {
        client::ReplicaSync whole = frame.takeSync(versions_, {});
        replica_.follow(whole);
        replica_.recordChanges(true);
        thread_ = std::thread([this] { run(); });
    }
    ~OpApplyThread() {
        {
            std::lock_guard lock(mutex_);
            stop_ = true;
        }
        cv_.notify_one();
        thread_.join();
    }
    OpApplyThread(const OpApplyThread&) = delete;
    OpApplyThread& operator=(const OpApplyThread&) = delete;

    /// Frame thread: ops read off the network this frame.
    void arrive(std::vector<Arrival> ops) {
        {
            std::lock_guard lock(mutex_);
            for (Arrival& a : ops)
                inbox_.push_back(a);
        }
        cv_.notify_one();
    }
    /// Frame thread: what the thread applied since the last call, for the frame's replica to
    /// follow (under the lock held for a move).
    std::vector<client::ReplicaSync> take() {
        std::lock_guard lock(mutex_);
        std::vector<client::ReplicaSync> out;
        out.swap(outbox_);
        return out;
    }
    /// Every op applied so far verified the server's hash.
    bool hashesAgree() const {
        std::lock_guard lock(mutex_);
        return hashes_agree_;
    }

  private:
    void run() {
        std::vector<Arrival> ops;
        for (;;) {
            {
                std::unique_lock lock(mutex_);
                cv_.wait(lock, [&] { return stop_ || !inbox_.empty(); });
                if (stop_)
                    return;
                ops.swap(inbox_);
            }
            bool agree = true;
            for (const Arrival& a : ops) {
                const auto outcome = replica_.applyOp(a.seq, a.op, a.world_hash);
                agree = agree && outcome && *outcome == client::Replica::OpOutcome::kApplied;
            }
            ops.clear();
            client::ReplicaSync sync = replica_.takeSync(versions_, replica_.takeChanges());
            (void)replica_.takeDirty(); // nothing draws this copy
            std::lock_guard lock(mutex_);
            hashes_agree_ = hashes_agree_ && agree;
            outbox_.push_back(std::move(sync));
        }
    }

    client::Replica replica_;
    std::vector<std::uint64_t> versions_; ///< the frame's copy's tiles, as of the last sync
    mutable std::mutex mutex_;
    std::condition_variable cv_;
    std::vector<Arrival> inbox_;
    std::vector<client::ReplicaSync> outbox_;
    bool hashes_agree_ = true;
    bool stop_ = false;
    std::thread thread_;
};

} // namespace terrain::bench
