#include "server_metrics.h"

#include <prometheus/text_serializer.h>

namespace terrain::server {
namespace {

prometheus::Histogram&
histogram(prometheus::Registry& r, const std::string& name, const std::string& help) {
    // 100 us to 10 s: an fdatasync on a good SSD to a snapshot of a large world
    const prometheus::Histogram::BucketBoundaries buckets = {
        0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025,
        0.05,   0.1,     0.25,   0.5,   1.0,    2.5,   5.0,  10.0};
    return prometheus::BuildHistogram().Name(name).Help(help).Register(r).Add({}, buckets);
}

prometheus::Counter*
counter(prometheus::Registry& r, const std::string& name, const std::string& help) {
    return &prometheus::BuildCounter().Name(name).Help(help).Register(r).Add({});
}

} // namespace

void ServerMetrics::Follower::follow(double total) {
    if (total > seen)
        counter->Increment(total - seen);
    seen = total;
}

ServerMetrics::ServerMetrics()
    : commit_seconds_(histogram(
          *registry_,
          "terrain_commit_seconds",
          "a group commit's journal write and fdatasync, on the commit thread")),
      snapshot_seconds_(histogram(
          *registry_,
          "terrain_snapshot_build_seconds",
          "a join snapshot or journal snapshot built on the snapshot thread")) {
    prometheus::Registry& r = *registry_;
    sessions_accepted_.counter =
        counter(r, "terrain_connections_accepted_total", "TCP connections accepted");
    ops_accepted_.counter =
        counter(r, "terrain_ops_accepted_total", "deform requests applied and numbered");
    ops_refused_.counter =
        counter(r, "terrain_ops_refused_total", "deform requests refused (any reason)");
    commits_.counter = counter(r, "terrain_commits_total", "group commits made durable");
    resyncs_.counter =
        counter(r, "terrain_resyncs_total", "sessions resynced by snapshot (backlog over budget)");
    slow_disconnects_.counter =
        counter(r, "terrain_slow_disconnects_total", "sessions closed as slow consumers");
    bad_frames_.counter = counter(r, "terrain_bad_frames_total", "frames that did not decode");
    bad_tokens_.counter = counter(r, "terrain_bad_tokens_total", "Hellos with a refused token");
    snapshots_built_.counter =
        counter(r, "terrain_join_snapshots_built_total", "join snapshots built (either kind)");
    snapshots_sent_.counter =
        counter(r, "terrain_snapshot_joins_total", "whole snapshots sent (joins and resyncs)");
    genesis_deltas_sent_.counter =
        counter(r, "terrain_genesis_delta_joins_total", "genesis deltas sent (joins)");
    repairs_served_.counter = counter(r, "terrain_repairs_total", "repair requests answered");
    bytes_queued_.counter =
        counter(r, "terrain_bytes_out_total", "bytes of frames handed to sessions (before TCP)");
    auto& sessions = prometheus::BuildGauge()
                         .Name("terrain_sessions")
                         .Help("sessions by state, and live ones by role")
                         .Register(r);
    awaiting_hello_ = &sessions.Add({{"state", "awaiting_hello"}});
    viewers_ = &sessions.Add({{"state", "live"}, {"role", "viewer"}});
    deformers_ = &sessions.Add({{"state", "live"}, {"role", "deformer"}});
    admins_ = &sessions.Add({{"state", "live"}, {"role", "admin"}});
    ending_ = &sessions.Add({{"state", "closing"}});
    queued_bytes_ = &prometheus::BuildGauge()
                         .Name("terrain_outbound_queued_bytes")
                         .Help("bytes queued to sessions, not yet written")
                         .Register(r)
                         .Add({});
    seq_ = &prometheus::BuildGauge()
                .Name("terrain_broadcast_seq")
                .Help("the last op broadcast")
                .Register(r)
                .Add({});
    ready_ = &prometheus::BuildGauge()
                  .Name("terrain_ready")
                  .Help("1 while serving; 0 once draining or failed")
                  .Register(r)
                  .Add({});
}

std::string ServerMetrics::scrape(const ServerHub& hub) {
    const ServerStats& s = hub.stats();
    sessions_accepted_.follow(static_cast<double>(s.sessions_accepted));
    ops_accepted_.follow(static_cast<double>(s.ops_accepted));
    ops_refused_.follow(static_cast<double>(s.ops_refused));
    commits_.follow(static_cast<double>(s.commits));
    resyncs_.follow(static_cast<double>(s.resyncs));
    slow_disconnects_.follow(static_cast<double>(s.slow_disconnects));
    bad_frames_.follow(static_cast<double>(s.bad_frames));
    bad_tokens_.follow(static_cast<double>(s.bad_tokens));
    snapshots_built_.follow(static_cast<double>(s.snapshots_built));
    snapshots_sent_.follow(static_cast<double>(s.snapshots_sent));
    genesis_deltas_sent_.follow(static_cast<double>(s.genesis_deltas_sent));
    repairs_served_.follow(static_cast<double>(s.repairs_served));
    bytes_queued_.follow(static_cast<double>(s.bytes_queued));
    const ServerHub::SessionCounts c = hub.sessionCounts();
    awaiting_hello_->Set(static_cast<double>(c.awaiting_hello));
    viewers_->Set(static_cast<double>(c.viewers));
    deformers_->Set(static_cast<double>(c.deformers));
    admins_->Set(static_cast<double>(c.admins));
    ending_->Set(static_cast<double>(c.ending));
    queued_bytes_->Set(static_cast<double>(hub.queuedBytes()));
    seq_->Set(static_cast<double>(hub.broadcastSeq()));
    ready_->Set(hub.failed() || hub.shuttingDown() ? 0.0 : 1.0);
    return prometheus::TextSerializer().Serialize(registry_->Collect());
}

} // namespace terrain::server
