// battle_feed: sends canonical ops (battle_bench --ops) to a running terrain-server as one
// deformer, at most --window requests unanswered, and waits until every request is answered and
// its replica holds the server's last op. For measuring a real server process under a battle
// (tests/bench/server_memory.sh, server_commit.sh). Prints accepted, refused, seconds, ops per
// second, request -> reply latency (median, p99, max), the final seq and hash. With --light the
// feeder keeps no replica: it sends, reads the replies and skips the ops, so that on a shared
// machine its CPU goes to the server (a game's players apply ops on machines of their own).
// Exit status: 0 when every op was answered and the replica verified; 1 otherwise; 2 on input.

#include "light_deformer.h"

#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/op_script.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

int main(int argc, char** argv) {
    using namespace terrain;
    CLI::App app{"battle_feed: canonical ops into a terrain-server, windowed"};
    std::string host = "127.0.0.1";
    std::uint16_t port = 7777;
    std::string token;
    std::string ops_path;
    int window = 64;
    double rate = 0.0;
    std::string sends_path;
    bool light = false;
    app.add_option("--host", host);
    app.add_option("--port", port)->required();
    app.add_option("--token", token, "a deformer token")->required();
    app.add_option("--ops", ops_path, "canonical ops, one per line")->required();
    app.add_option("--window", window, "requests in flight at most")->check(CLI::Range(1, 100000));
    app.add_option("--rate", rate, "paced: requests per second at most (0: as the window allows)")
        ->check(CLI::NonNegativeNumber);
    app.add_option(
        "--sends", sends_path,
        "write 'seq nanoseconds' (steady clock) of each accepted op's request (load_viewers "
        "merge)");
    app.add_flag("--light", light, "keep no replica: send, read replies, skip the ops");
    CLI11_PARSE(app, argc, argv);

    std::ifstream file(ops_path);
    std::stringstream text;
    text << file.rdbuf();
    Result<std::vector<DeformOp>> ops = parseCanonicalOps(text.str());
    if (!file || !ops) {
        std::fprintf(
            stderr, "battle_feed: %s: %s\n", ops_path.c_str(),
            ops ? "cannot read" : ops.error().message.c_str());
        return 2;
    }
    asio::io_context io;
    client::Replica replica;
    client::ConnectionConfig config;
    config.host = host;
    config.port = port;
    config.token = token;
    config.client_name = "battle_feed";
    auto connection = std::make_shared<client::Connection>(io, config, replica);
    std::optional<bench::LightDeformer> lightweight;
    std::size_t sent = 0;
    std::size_t answered = 0;
    std::size_t accepted = 0;
    std::uint64_t last_accepted = 0;
    std::vector<std::chrono::steady_clock::time_point> sent_at(ops->size());
    std::vector<double> latency_ms;
    latency_ms.reserve(ops->size());
    std::vector<std::pair<std::uint64_t, std::chrono::steady_clock::time_point>> accepted_sends;
    connection->on_deform_reply = [&](const client::DeformAnswer& a) {
        // request ids count from 1 in the order sent
        const std::size_t i = a.request_id - 1;
        if (i < sent_at.size())
            latency_ms.push_back(std::chrono::duration<double, std::milli>(
                                     std::chrono::steady_clock::now() - sent_at[i])
                                     .count());
        ++answered;
        if (a.accepted && i < sent_at.size())
            accepted_sends.emplace_back(a.seq, sent_at[i]);
        if (a.accepted) {
            ++accepted;
            last_accepted = std::max(last_accepted, a.seq);
        }
    };
    if (light) {
        lightweight.emplace(io, host, port, token);
        lightweight->on_reply = connection->on_deform_reply;
    } else
        connection->start();
    const auto joined = [&] { return light ? lightweight->joined() : connection->synced(); };
    const auto start = std::chrono::steady_clock::now();
    const auto elapsed = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    std::optional<std::chrono::steady_clock::time_point> paced_from;
    while (elapsed() < 600.0) {
        io.run_for(std::chrono::milliseconds(1));
        if (light && lightweight->failed())
            break;
        if (!joined())
            continue;
        if (!paced_from)
            paced_from = std::chrono::steady_clock::now(); // joined: the pacing starts
        const auto paced_limit = [&] {
            const double since =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - *paced_from)
                    .count();
            return rate > 0.0 ? static_cast<std::size_t>(since * rate) + 1 : ops->size();
        };
        while (sent < ops->size() && sent - answered < static_cast<std::size_t>(window) &&
               sent < paced_limit()) {
            sent_at[sent] = std::chrono::steady_clock::now();
            if (light)
                lightweight->request((*ops)[sent++]);
            else
                connection->requestDeform((*ops)[sent++]);
        }
        if (answered == ops->size() && (light || replica.seq() >= last_accepted))
            break;
    }
    const double seconds = elapsed();
    const bool ok = answered == ops->size() && (light || connection->synced());
    std::sort(latency_ms.begin(), latency_ms.end());
    const auto rank = [&](double q) {
        return latency_ms.empty()
                   ? 0.0
                   : latency_ms[std::min(
                         latency_ms.size() - 1,
                         static_cast<std::size_t>(q * static_cast<double>(latency_ms.size())))];
    };
    std::printf(
        "battle_feed: %zu ops, %zu accepted, %zu refused, %.1f s (%.0f ops/s); request -> reply "
        "p50 %.2f ms, p99 %.2f ms, max %.2f ms; broadcasts %.1f bytes an op (%llu batches); "
        "replica at seq %llu, hash %016llx%s\n",
        ops->size(), accepted, answered - accepted, seconds,
        static_cast<double>(ops->size()) / seconds, rank(0.5), rank(0.99),
        latency_ms.empty() ? 0.0 : latency_ms.back(),
        accepted > 0 ? static_cast<double>(
                           light ? lightweight->opBytes() : connection->stats().op_bytes_in) /
                           static_cast<double>(accepted)
                     : 0.0,
        static_cast<unsigned long long>(connection->stats().op_batches),
        static_cast<unsigned long long>(light ? last_accepted : replica.seq()),
        static_cast<unsigned long long>(replica.worldHash()),
        !ok     ? " (INCOMPLETE)"
        : light ? " (light: no replica, nothing verified)"
                : "");
    if (!sends_path.empty()) {
        std::ofstream sends(sends_path);
        for (const auto& [seq, at] : accepted_sends)
            sends << seq << ' '
                  << std::chrono::duration_cast<std::chrono::nanoseconds>(at.time_since_epoch())
                         .count()
                  << '\n';
    }
    connection->stop();
    io.run_for(std::chrono::milliseconds(10));
    return ok ? 0 : 1;
}
