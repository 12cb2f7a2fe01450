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

// the hub's running totals, exposed as counters
struct CounterSpec {
    std::uint64_t ServerStats::*total;
    const char* name;
    const char* help;
};
constexpr CounterSpec kCounters[] = {
    {&ServerStats::sessions_accepted, "terrain_connections_accepted_total",
     "TCP connections accepted"},
    {&ServerStats::ops_accepted, "terrain_ops_accepted_total",
     "deform requests applied and numbered"},
    {&ServerStats::commits, "terrain_commits_total", "group commits made durable"},
    {&ServerStats::resyncs, "terrain_resyncs_total",
     "sessions resynced by snapshot (backlog over budget)"},
    {&ServerStats::slow_disconnects, "terrain_slow_disconnects_total",
     "sessions closed as slow consumers"},
    {&ServerStats::bad_frames, "terrain_bad_frames_total", "frames that did not decode"},
    {&ServerStats::bad_tokens, "terrain_bad_tokens_total", "Hellos with a refused token"},
    {&ServerStats::snapshots_built, "terrain_join_snapshots_built_total",
     "join snapshots built (either kind)"},
    {&ServerStats::snapshots_sent, "terrain_snapshot_joins_total",
     "whole snapshots sent (joins and resyncs)"},
    {&ServerStats::genesis_deltas_sent, "terrain_genesis_delta_joins_total",
     "genesis deltas sent (joins)"},
    {&ServerStats::repairs_served, "terrain_repairs_total", "repair requests answered"},
    {&ServerStats::bytes_queued, "terrain_bytes_out_total",
     "bytes of frames handed to sessions (before TCP)"},
    {&ServerStats::bytes_received, "terrain_bytes_in_total", "bytes read from sessions"},
};

} // namespace

ServerMetrics::ServerMetrics()
    : commit_seconds_(histogram(
          *registry_,
          "terrain_commit_seconds",
          "a group commit's journal write and fdatasync, on the commit thread")),
      snapshot_seconds_(histogram(
          *registry_,
          "terrain_snapshot_build_seconds",
          "a join snapshot or journal snapshot built on the snapshot thread")),
      apply_seconds_(histogram(
          *registry_,
          "terrain_op_apply_seconds",
          "an accepted op's validation and apply to the authority's terrain, on the io thread")),
      broadcast_seconds_(histogram(
          *registry_,
          "terrain_broadcast_latency_seconds",
          "a deform request's arrival to its op's broadcast and acknowledgement (the group "
          "commit's fdatasync included)")),
      join_seconds_(histogram(
          *registry_,
          "terrain_join_seconds",
          "a Hello to the join's frames queued (resume, snapshot or genesis delta; waits for a "
          "snapshot build included)")) {
    prometheus::Registry& r = *registry_;
    for (const CounterSpec& c : kCounters)
        followers_.push_back(
            {c.total, &prometheus::BuildCounter().Name(c.name).Help(c.help).Register(r).Add({})});
    refused_ = &prometheus::BuildCounter()
                    .Name("terrain_ops_refused_total")
                    .Help("deform requests refused, by reason (the wire's REASON_ name)")
                    .Register(r);
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
    const auto gauge = [&](const char* name, const char* help) {
        return &prometheus::BuildGauge().Name(name).Help(help).Register(r).Add({});
    };
    replay_pending_ = gauge(
        "terrain_journal_replay_pending_seconds",
        "measured apply time of the durable ops after the last journal snapshot: about what a "
        "recovery would replay now");
    recovery_seconds_ = gauge(
        "terrain_recovery_seconds",
        "the start-up recovery: snapshot load and replay (0: new world)");
    recovery_records_ =
        gauge("terrain_recovery_replayed_records", "records the start-up recovery replayed");
    recovery_snapshot_seq_ =
        gauge("terrain_recovery_snapshot_seq", "the snapshot the start-up recovery started from");
}

void ServerMetrics::setRecovery(const RecoveryReport& report) {
    recovery_seconds_->Set(report.seconds);
    recovery_records_->Set(static_cast<double>(report.replayed_records));
    recovery_snapshot_seq_->Set(static_cast<double>(report.snapshot_seq));
}

void ServerMetrics::observe(HubTiming timing, double seconds) {
    switch (timing) {
    case HubTiming::kApply:
        apply_seconds_.Observe(seconds);
        break;
    case HubTiming::kBroadcast:
        broadcast_seconds_.Observe(seconds);
        break;
    case HubTiming::kJoin:
        join_seconds_.Observe(seconds);
        break;
    }
}

std::string ServerMetrics::scrape(const ServerHub& hub) {
    const ServerStats& s = hub.stats();
    for (Follower& f : followers_) {
        const auto total = static_cast<double>(s.*f.total);
        if (total > f.seen)
            f.counter->Increment(total - f.seen);
        f.seen = total;
    }
    for (std::size_t reason = 0; reason < kReasonSlots; ++reason) {
        const auto total = static_cast<double>(s.refused_by_reason[reason]);
        if (total > refused_seen_[reason]) {
            const std::string name = wire::pb::Reason_IsValid(static_cast<int>(reason))
                                         ? wire::pb::Reason_Name(static_cast<int>(reason))
                                         : "REASON_" + std::to_string(reason);
            refused_->Add({{"reason", name}}).Increment(total - refused_seen_[reason]);
            refused_seen_[reason] = total;
        }
    }
    const ServerHub::SessionCounts c = hub.sessionCounts();
    awaiting_hello_->Set(static_cast<double>(c.awaiting_hello));
    viewers_->Set(static_cast<double>(c.viewers));
    deformers_->Set(static_cast<double>(c.deformers));
    admins_->Set(static_cast<double>(c.admins));
    ending_->Set(static_cast<double>(c.ending));
    queued_bytes_->Set(static_cast<double>(hub.queuedBytes()));
    seq_->Set(static_cast<double>(hub.broadcastSeq()));
    ready_->Set(hub.failed() || hub.shuttingDown() ? 0.0 : 1.0);
    replay_pending_->Set(hub.replaySecondsSinceSnapshot());
    return prometheus::TextSerializer().Serialize(registry_->Collect());
}

} // namespace terrain::server
