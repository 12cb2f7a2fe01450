#pragma once

// The server's Prometheus metrics, kept in prometheus-cpp's registry and written in its text
// format. Counters and gauges are read from the hub when scraped (the hub keeps the counts,
// pure); histograms are observed by the shell where it times work: a group commit's write and
// fdatasync, a snapshot build. Private to terrain_server_net.

#include <terrain/server/server.h>
#include <terrain/server/server_hub.h>

#include <prometheus/counter.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace terrain::server {

class ServerMetrics {
  public:
    ServerMetrics();

    /// Any thread.
    void observeCommit(double seconds) { commit_seconds_.Observe(seconds); }
    void observeSnapshotBuild(double seconds) { snapshot_seconds_.Observe(seconds); }
    /// Once, before serving.
    void setRecovery(const RecoveryReport& report);
    /// Io thread: the hub's own timings.
    void observe(HubTiming timing, double seconds);

    /// Io thread: the text exposition with the hub's figures as they stand.
    std::string scrape(const ServerHub& hub);

  private:
    /// A counter that follows one of the hub's running totals.
    struct Follower {
        std::uint64_t ServerStats::*total;
        prometheus::Counter* counter = nullptr;
        double seen = 0.0;
    };

    std::shared_ptr<prometheus::Registry> registry_ = std::make_shared<prometheus::Registry>();
    prometheus::Histogram& commit_seconds_;
    prometheus::Histogram& snapshot_seconds_;
    prometheus::Histogram& apply_seconds_;
    prometheus::Histogram& broadcast_seconds_;
    prometheus::Histogram& join_seconds_;
    /// terrain_ops_refused_total{reason}: series made as reasons first appear
    prometheus::Family<prometheus::Counter>* refused_ = nullptr;
    std::array<double, kReasonSlots> refused_seen_{};
    std::vector<Follower> followers_;
    prometheus::Gauge* awaiting_hello_ = nullptr;
    prometheus::Gauge* viewers_ = nullptr;
    prometheus::Gauge* deformers_ = nullptr;
    prometheus::Gauge* admins_ = nullptr;
    prometheus::Gauge* ending_ = nullptr;
    prometheus::Gauge* queued_bytes_ = nullptr;
    prometheus::Gauge* seq_ = nullptr;
    prometheus::Gauge* ready_ = nullptr;
    prometheus::Gauge* replay_pending_ = nullptr;
    prometheus::Gauge* recovery_seconds_ = nullptr;
    prometheus::Gauge* recovery_records_ = nullptr;
    prometheus::Gauge* recovery_snapshot_seq_ = nullptr;
};

} // namespace terrain::server
