// battle_feed: sends canonical ops (battle_bench --ops) to a running terrain-server as one
// deformer, at most --window requests unanswered, and waits until every request is answered and
// its replica holds the server's last op. For measuring a real server process under a battle
// (tests/bench/server_memory.sh). Prints accepted, refused, seconds, the final seq and hash.
// Exit status: 0 when every op was answered and the replica verified; 1 otherwise; 2 on input.

#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/op_script.h>

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
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
    app.add_option("--host", host);
    app.add_option("--port", port)->required();
    app.add_option("--token", token, "a deformer token")->required();
    app.add_option("--ops", ops_path, "canonical ops, one per line")->required();
    app.add_option("--window", window, "requests in flight at most")->check(CLI::Range(1, 100000));
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
    std::size_t sent = 0;
    std::size_t answered = 0;
    std::size_t accepted = 0;
    std::uint64_t last_accepted = 0;
    connection->on_deform_reply = [&](const client::DeformAnswer& a) {
        ++answered;
        if (a.accepted) {
            ++accepted;
            last_accepted = std::max(last_accepted, a.seq);
        }
    };
    connection->start();
    const auto start = std::chrono::steady_clock::now();
    const auto elapsed = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    while (elapsed() < 600.0) {
        io.run_for(std::chrono::milliseconds(1));
        if (!connection->synced())
            continue;
        while (sent < ops->size() && sent - answered < static_cast<std::size_t>(window))
            connection->requestDeform((*ops)[sent++]);
        if (answered == ops->size() && replica.seq() >= last_accepted)
            break;
    }
    const bool ok = answered == ops->size() && connection->synced();
    std::printf(
        "battle_feed: %zu ops, %zu accepted, %zu refused, %.1f s; replica at seq %llu, hash "
        "%016llx%s\n",
        ops->size(), accepted, answered - accepted, elapsed(),
        static_cast<unsigned long long>(replica.seq()),
        static_cast<unsigned long long>(replica.worldHash()), ok ? "" : " (INCOMPLETE)");
    connection->stop();
    io.run_for(std::chrono::milliseconds(10));
    return ok ? 0 : 1;
}
