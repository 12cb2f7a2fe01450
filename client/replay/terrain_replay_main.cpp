// terrain-replay: consistency checks of a recorded match.
//   terrain-replay [verify] DIR [--json]   offline: replays every record of a journal directory
//                                          from its oldest snapshot, checks world hashes, seq
//                                          continuity and later snapshots (verifyJournal())
//   terrain-replay live DIR [options]      through a live server (this build) to N clients,
//                                          every client's hash checked at every seq; a desync
//                                          report on the first divergence (live_replay.h)
//   terrain-replay soak DIR [options]      fuzzed ops through a live server keeping its journal
//                                          in DIR, to N clients; then the journal replayed
//                                          offline, every client's hash compared at every seq
// Exit 0 when sound and agreed, 1 when a rule is broken or a client diverged, 2 for bad
// arguments, 3 when the live run hit its time limit.

#include <terrain/journal/journal.h>
#include <terrain/replay/desync_report.h>
#include <terrain/replay/live_replay.h>
#include <terrain/replay/soak.h>

#include <CLI/CLI.hpp>

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

std::string jsonString(const std::string& text) {
    std::string out = "\"";
    for (const char c : text) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else if (static_cast<unsigned char>(c) < 0x20) {
            char escaped[8];
            std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned>(c));
            out += escaped;
        } else {
            out += c;
        }
    }
    return out + "\"";
}

int verify(const std::string& dir, bool json) {
    const auto report = terrain::journal::verifyJournal(dir);
    if (!report) {
        const terrain::Error& e = report.error();
        if (json)
            std::printf(
                "{\"ok\":false,\"code\":%s,\"error\":%s}\n",
                jsonString(terrain::toString(e.code)).c_str(), jsonString(e.message).c_str());
        else
            std::fprintf(
                stderr, "terrain-replay: %s: %s (%s)\n", dir.c_str(), e.message.c_str(),
                terrain::toString(e.code));
        return 1;
    }
    const auto& r = *report;
    if (json) {
        std::printf(
            "{\"ok\":true,\"records\":%zu,\"base_seq\":%" PRIu64 ",\"last_seq\":%" PRIu64
            ",\"segments\":%zu,\"snapshots_checked\":%zu,\"final_world_hash\":\"%016" PRIx64
            "\",\"torn_bytes\":%zu}\n",
            r.records_checked, r.base_seq, r.last_seq, r.segments_checked, r.snapshots_checked,
            r.final_hash, r.torn_bytes);
        return 0;
    }
    std::printf("journal    : %s\n", dir.c_str());
    std::printf("records    : %zu", r.records_checked);
    if (r.records_checked > 0)
        std::printf(" (seq %" PRIu64 "..%" PRIu64 ")", r.base_seq + 1, r.last_seq);
    std::printf("\nbase       : snapshot at seq %" PRIu64 "\n", r.base_seq);
    std::printf("segments   : %zu\n", r.segments_checked);
    std::printf("snapshots  : %zu checked\n", r.snapshots_checked);
    std::printf("world hash : %016" PRIx64 " at seq %" PRIu64 "\n", r.final_hash, r.last_seq);
    std::printf(
        "torn bytes : %zu%s\n", r.torn_bytes,
        r.torn_bytes > 0 ? " (at the end of the newest segment; recovery drops them)" : "");
    return 0;
}

int live(
    const std::string& dir,
    const terrain::replay::LiveRunOptions& options,
    const std::string& report_dir,
    bool json) {
    using namespace terrain;
    auto history = journal::readJournal(dir);
    if (!history) {
        std::fprintf(
            stderr, "terrain-replay: %s: %s (%s)\n", dir.c_str(), history.error().message.c_str(),
            toString(history.error().code));
        return 1;
    }
    if (!json)
        std::printf(
            "terrain-replay: %s: %zu ops after seq %" PRIu64
            " (verified offline); replaying through a live server to %zu clients\n",
            dir.c_str(), history->records.size(), history->base_seq, options.clients);
    auto run = replay::runLiveReplay(*history, options);
    if (!run) {
        std::fprintf(stderr, "terrain-replay: %s\n", run.error().message.c_str());
        return 1;
    }
    const replay::LiveRunResult& r = *run;
    std::string report_path;
    if (r.first_divergence) {
        const replay::Divergence& d = *r.first_divergence;
        auto expected = replay::stateAt(*history, d.seq);
        if (!expected) {
            std::fprintf(stderr, "terrain-replay: %s\n", expected.error().message.c_str());
            return 1;
        }
        replay::DesyncFacts facts;
        facts.seq = d.seq;
        facts.op = d.op;
        facts.where = dir;
        facts.who = r.clients[d.client].name +
                    (d.server_differs ? " agrees with the live server: this build's server "
                                        "differs from the journal"
                                      : " differs from the live server it follows");
        facts.expected_hash = d.expected_hash;
        facts.observed_hash = d.observed_hash;
        const std::string folder = report_dir + "/desync-" + std::to_string(d.seq);
        if (Status s = replay::writeDesyncReport(folder, facts, *expected, *d.observed); !s) {
            std::fprintf(stderr, "terrain-replay: %s\n", s.error().message.c_str());
            return 1;
        }
        report_path = folder;
    }
    if (json) {
        std::printf(
            "{\"agreed\":%s,\"base_seq\":%" PRIu64 ",\"last_seq\":%" PRIu64 ",\"ops_fed\":%" PRIu64
            ",\"ops_refused\":%" PRIu64
            ",\"seconds\":%.3f,\"timed_out\":%s,\"first_divergence\":%s,\"report\":%s,"
            "\"clients\":[",
            replayAgreed(*history, r) ? "true" : "false", r.base_seq, r.last_seq, r.ops_fed,
            r.refused(), r.seconds, r.timed_out ? "true" : "false",
            r.first_divergence ? std::to_string(r.first_divergence->seq).c_str() : "null",
            report_path.empty() ? "null" : jsonString(report_path).c_str());
        for (std::size_t i = 0; i < r.clients.size(); ++i) {
            const replay::ClientTally& c = r.clients[i];
            std::printf(
                "%s{\"name\":%s,\"checked\":%" PRIu64 ",\"mismatches\":%" PRIu64
                ",\"repairs\":%" PRIu64 ",\"snapshots\":%" PRIu64 ",\"final_seq\":%" PRIu64
                ",\"final_hash\":\"%016" PRIx64 "\"}",
                i ? "," : "", jsonString(c.name).c_str(), c.checked, c.mismatches, c.repairs,
                c.snapshots, c.final_seq, c.final_hash);
        }
        std::printf("]}\n");
    } else {
        std::printf(
            "client       checked  mismatches  repairs  snapshots  final seq  world hash\n");
        for (const replay::ClientTally& c : r.clients)
            std::printf(
                "%-12s %7" PRIu64 " %11" PRIu64 " %8" PRIu64 " %10" PRIu64 " %10" PRIu64
                "  %016" PRIx64 "%s%s\n",
                c.name.c_str(), c.checked, c.mismatches, c.repairs, c.snapshots, c.final_seq,
                c.final_hash,
                c.last_disconnect.empty() ? "" : "  dropped: ", c.last_disconnect.c_str());
        std::printf(
            "terrain-replay: %" PRIu64
            " ops fed in %.2f s (%.0f ops/s); journal ends at seq %" PRIu64
            " with world hash %016" PRIx64 "\n",
            r.ops_fed, r.seconds, r.seconds > 0 ? double(r.ops_fed) / r.seconds : 0.0, r.last_seq,
            history->report.final_hash);
        if (r.refused() > 0)
            std::printf(
                "terrain-replay: the live server refused %" PRIu64 " ops; first: %s\n", r.refused(),
                r.first_refusal.c_str());
        if (r.first_divergence)
            std::printf(
                "terrain-replay: DESYNC at seq %" PRIu64 "; report in %s (report.txt first)\n",
                r.first_divergence->seq, report_path.c_str());
        if (r.timed_out)
            std::printf("terrain-replay: time limit reached before the end of the journal\n");
        std::printf(
            "terrain-replay: %s\n", replayAgreed(*history, r)
                                        ? "AGREED: every client matched the journal at every seq"
                                        : "NOT AGREED");
    }
    if (r.timed_out && !r.first_divergence && r.refused() == 0)
        return 3;
    return replayAgreed(*history, r) ? 0 : 1;
}

int soak(const terrain::replay::SoakOptions& options, bool json) {
    using namespace terrain;
    auto run = replay::runSoak(options);
    if (!run) {
        std::fprintf(stderr, "terrain-replay: soak: %s\n", run.error().message.c_str());
        return 1;
    }
    const replay::SoakResult& r = *run;
    const replay::LiveRunResult& l = r.live;
    const double ops_per_second = l.seconds > 0 ? double(l.ops_fed) / l.seconds : 0.0;
    if (json) {
        std::string refusals;
        for (const auto& [reason, count] : l.refusals)
            refusals +=
                (refusals.empty() ? "" : ",") + jsonString(reason) + ":" + std::to_string(count);
        std::printf(
            "{\"agreed\":%s,\"ops\":%" PRIu64 ",\"battle\":%" PRIu64 ",\"random\":%" PRIu64
            ",\"extreme\":%" PRIu64 ",\"largest\":%" PRIu64 ",\"invalid\":%" PRIu64
            ",\"accepted\":%" PRIu64 ",\"refusals\":{%s},\"clients\":%zu,\"live_seconds\":%.3f,"
            "\"ops_per_second\":%.1f,\"offline_seconds\":%.3f,\"seqs_compared\":%" PRIu64
            ",\"disagreements\":%" PRIu64 ",\"repairs\":%" PRIu64 ",\"final_seq\":%" PRIu64
            ",\"final_hash\":\"%016" PRIx64 "\",\"timed_out\":%s}\n",
            r.agreed() ? "true" : "false", l.ops_fed, r.counts.battle, r.counts.random,
            r.counts.extreme, r.counts.largest, r.counts.invalid, l.ops_accepted, refusals.c_str(),
            l.clients.size(), l.seconds, ops_per_second, r.offline_seconds, r.seqs_compared,
            r.disagreements,
            [&] {
                std::uint64_t n = 0;
                for (const auto& c : l.clients)
                    n += c.repairs;
                return n;
            }(),
            r.offline.last_seq, r.offline.final_hash, l.timed_out ? "true" : "false");
    } else {
        std::printf(
            "soak: %" PRIu64 " ops (battle %" PRIu64 ", random %" PRIu64 ", extreme %" PRIu64
            " of which %" PRIu64 " at the largest radius, invalid %" PRIu64 ") to %zu clients\n",
            l.ops_fed, r.counts.battle, r.counts.random, r.counts.extreme, r.counts.largest,
            r.counts.invalid, l.clients.size());
        std::printf(
            "soak: live %.2f s (%.0f ops/s): %" PRIu64 " accepted, %" PRIu64 " refused\n",
            l.seconds, ops_per_second, l.ops_accepted, l.refused());
        for (const auto& [reason, count] : l.refusals)
            std::printf("        %-28s %" PRIu64 "\n", reason.c_str(), count);
        std::printf(
            "soak: journal replayed offline in %.2f s: %zu records, seq %" PRIu64
            ", world hash %016" PRIx64 "\n",
            r.offline_seconds, r.offline.records_checked, r.offline.last_seq, r.offline.final_hash);
        std::printf(
            "soak: %" PRIu64 " client-seq hashes compared with the journal, %" PRIu64
            " disagree%s%s\n",
            r.seqs_compared, r.disagreements,
            r.first_disagreement.empty() ? "" : "; first: ", r.first_disagreement.c_str());
        std::printf("soak: %s\n", r.agreed() ? "AGREED at every seq" : "NOT AGREED");
    }
    if (l.timed_out)
        return 3;
    return r.agreed() ? 0 : 1;
}

} // namespace

int main(int argc, char** argv) {
    // `terrain-replay DIR` still means verify
    std::vector<char*> args(argv, argv + argc);
    static char verify_word[] = "verify";
    if (argc > 1 && std::strcmp(argv[1], "verify") != 0 && std::strcmp(argv[1], "live") != 0 &&
        std::strcmp(argv[1], "soak") != 0 && argv[1][0] != '-')
        args.insert(args.begin() + 1, verify_word);
    else if (
        argc > 1 && argv[1][0] == '-' && std::strcmp(argv[1], "-h") != 0 &&
        std::strcmp(argv[1], "--help") != 0)
        args.insert(args.begin() + 1, verify_word);

    CLI::App app{"terrain-replay: consistency checks of a recorded match (a journal directory)"};
    app.require_subcommand(1);
    std::string dir;
    bool json = false;
    CLI::App* verify_cmd = app.add_subcommand(
        "verify", "offline: replay every record, check hashes, continuity and snapshots (the "
                  "default)");
    verify_cmd->add_option("data-dir", dir, "journal directory (snapshots and segments)")
        ->required();
    verify_cmd->add_flag("--json", json, "print the report or the error as one JSON object");

    terrain::replay::LiveRunOptions options;
    std::string report_dir = ".";
    CLI::App* live_cmd = app.add_subcommand(
        "live", "through a live server (this build) to N clients, every hash checked at every "
                "seq; a desync report on the first divergence");
    live_cmd->add_option("data-dir", dir, "journal directory (snapshots and segments)")->required();
    live_cmd->add_option("--clients", options.clients, "clients checked at every seq")
        ->check(CLI::Range(1, 256));
    live_cmd
        ->add_option(
            "--time-limit", options.time_limit_seconds, "seconds; the run stops there (exit 3)")
        ->check(CLI::PositiveNumber);
    live_cmd->add_option("--window", options.window, "ops in flight ahead of the slowest client")
        ->check(CLI::Range(1, 100000));
    live_cmd->add_flag(
        "--batch-broadcasts", options.batch_broadcasts, "the server batches its broadcasts");
    live_cmd->add_option(
        "--report-dir", report_dir, "where a desync report's folder (desync-<seq>) goes");
    live_cmd->add_flag("--json", json, "print the result as one JSON object");
    terrain::replay::SoakOptions soak_options;
    std::string soak_dir;
    CLI::App* soak_cmd = app.add_subcommand(
        "soak", "fuzzed ops through a live server keeping its journal in DIR (new), to N clients; "
                "then the journal replayed offline and every client's hash compared at every seq");
    soak_cmd->add_option("dir", soak_dir, "the server's journal directory (must not exist)")
        ->required();
    soak_cmd->add_option("--ops", soak_options.ops, "ops to send")->check(CLI::Range(1, 100000000));
    soak_cmd->add_option("--clients", soak_options.live.clients, "clients checked at every seq")
        ->check(CLI::Range(1, 256));
    soak_cmd->add_option("--seed", soak_options.seed, "the map's and the ops' seed");
    soak_cmd->add_option("--map-size", soak_options.map_size, "vertices per side")
        ->check(CLI::Range(65, 4097));
    soak_cmd->add_option("--window", soak_options.live.window, "ops in flight")
        ->check(CLI::Range(1, 100000));
    soak_cmd
        ->add_option(
            "--time-limit", soak_options.live.time_limit_seconds,
            "seconds for the live part; the run stops there (exit 3)")
        ->check(CLI::PositiveNumber);
    soak_cmd->add_flag(
        "--batch-broadcasts", soak_options.live.batch_broadcasts,
        "the server batches its broadcasts");
    soak_cmd->add_flag("--json", json, "print the result as one JSON object");
    try {
        app.parse(static_cast<int>(args.size()), args.data());
    } catch (const CLI::ParseError& e) {
        // --help is a ParseError too, with exit code 0
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    }
    if (live_cmd->parsed())
        return live(dir, options, report_dir, json);
    if (soak_cmd->parsed()) {
        soak_options.directory = soak_dir;
        return soak(soak_options, json);
    }
    return verify(dir, json);
}
