// load_viewers: many light viewers in one process, for load runs with clients in separate
// processes (tests/bench/server_load.sh). Each viewer joins a terrain-server over TCP, skips its
// snapshot's bytes, decodes every OpApplied and OpBatch, and tracks the seq; nothing is applied
// (a client's own apply cost is measured elsewhere). The process records, for every seq, when
// the last of its viewers received it (steady clock: comparable across processes on one
// machine), and writes "seq nanoseconds" lines once every viewer reached --until.
//   load_viewers run --port P --token T --viewers N --until SEQ --out FILE
//   load_viewers merge --sends FEED_FILE --receipts A B ...   latency: sent -> received by all
// Exit status: 0; 1 when a viewer failed or the run timed out; 2 on bad input.

#include "support/bench_facts.h"

#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>
#include <terrain/wire/op_batch.h>

#include <CLI/CLI.hpp>

#include <asio.hpp>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace terrain;
namespace pb = wire::pb;

std::int64_t nowNs() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

struct Shared {
    std::uint64_t until = 0;
    std::vector<std::int64_t> last_ns; ///< per seq: the latest receipt over this process's viewers
    int failed = 0;
    int done = 0;
};

class Viewer {
  public:
    Viewer(asio::io_context& io, std::uint16_t port, const std::string& token, Shared& shared)
        : socket_(io), shared_(shared) {
        pb::Envelope e;
        e.mutable_hello()->set_protocol_version(wire::kProtocolVersion);
        e.mutable_hello()->set_token(token);
        e.mutable_hello()->set_client_name("load_viewers");
        wire::appendFrame(e, hello_);
        socket_.async_connect(
            {asio::ip::make_address("127.0.0.1"), port}, [this](const asio::error_code& ec) {
                if (ec)
                    return fail("connect: " + ec.message());
                socket_.set_option(asio::ip::tcp::no_delay(true));
                asio::async_write(socket_, asio::buffer(hello_), [](auto, auto) {});
                read();
            });
    }

  private:
    void fail(const std::string& why) {
        if (finished_)
            return;
        finished_ = true;
        ++shared_.failed;
        std::fprintf(stderr, "load_viewers: a viewer: %s\n", why.c_str());
    }
    void received(std::uint64_t seq, std::int64_t at) {
        if (seq != seq_ + 1 && seq_ != 0)
            return fail("seq " + std::to_string(seq) + " after " + std::to_string(seq_));
        seq_ = seq;
        if (seq < shared_.last_ns.size())
            shared_.last_ns[seq] = std::max(shared_.last_ns[seq], at);
        if (seq_ >= shared_.until && !finished_) {
            finished_ = true;
            ++shared_.done;
        }
    }
    void read() {
        const std::span<std::uint8_t> space = reader_.prepare(64 << 10);
        socket_.async_read_some(
            asio::buffer(space.data(), space.size()),
            [this](const asio::error_code& ec, std::size_t n) {
                if (ec)
                    return fail("read: " + ec.message());
                const std::int64_t at = nowNs();
                reader_.commit(n);
                for (;;) {
                    auto next = reader_.next();
                    if (!next)
                        return fail("bad frame: " + next.error().message);
                    if (!next->has_value())
                        break;
                    auto e = wire::decodeEnvelope(**next);
                    if (!e)
                        return fail(e.error().message);
                    if (e->has_snapshot_begin()) {
                        seq_ = e->snapshot_begin().seq();
                    } else if (e->has_op_applied()) {
                        received(wire::appliedSeq(e->op_applied(), seq_), at);
                    } else if (e->has_op_batch()) {
                        auto ops = wire::batchFromWire(e->op_batch(), seq_);
                        if (!ops)
                            return fail(ops.error().message);
                        for (const wire::BatchedOp& b : *ops)
                            received(b.seq, at);
                    } else if (e->has_disconnect()) {
                        return fail("disconnected: " + e->disconnect().message());
                    }
                }
                read();
            });
    }

    asio::ip::tcp::socket socket_;
    Shared& shared_;
    wire::FrameReader reader_{std::size_t{64} << 20};
    std::vector<std::uint8_t> hello_;
    std::uint64_t seq_ = 0;
    bool finished_ = false;
};

std::map<std::uint64_t, std::int64_t> readPairs(const std::string& path) {
    std::map<std::uint64_t, std::int64_t> out;
    std::ifstream in(path);
    std::uint64_t seq = 0;
    std::int64_t ns = 0;
    while (in >> seq >> ns)
        out[seq] = ns;
    return out;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"load_viewers: light viewers for multi-process load runs"};
    app.require_subcommand(1);
    std::uint16_t port = 0;
    std::string token;
    int viewers = 16;
    std::uint64_t until = 0;
    double timeout = 300.0;
    std::string out;
    CLI::App* run = app.add_subcommand("run", "join, receive until a seq, write receipts");
    run->add_option("--port", port)->required();
    run->add_option("--token", token, "a viewer token")->required();
    run->add_option("--viewers", viewers)->check(CLI::Range(1, 4096));
    run->add_option("--until", until, "stop once every viewer received this seq")->required();
    run->add_option("--timeout", timeout, "seconds");
    run->add_option("--out", out, "receipts: seq nanoseconds, one per line")->required();
    std::string sends;
    std::vector<std::string> receipts;
    CLI::App* merge = app.add_subcommand("merge", "sent -> received by every viewer");
    merge->add_option("--sends", sends, "battle_feed --sends file")->required();
    merge->add_option("--receipts", receipts, "load_viewers run --out files")->required();
    CLI11_PARSE(app, argc, argv);

    if (merge->parsed()) {
        const auto sent = readPairs(sends);
        std::vector<std::map<std::uint64_t, std::int64_t>> got;
        for (const std::string& r : receipts)
            got.push_back(readPairs(r));
        std::vector<double> latency_ms;
        std::size_t missing = 0;
        for (const auto& [seq, ns] : sent) {
            std::int64_t last = 0;
            bool all = true;
            for (const auto& g : got) {
                const auto it = g.find(seq);
                if (it == g.end()) {
                    all = false;
                    break;
                }
                last = std::max(last, it->second);
            }
            if (!all) {
                ++missing;
                continue;
            }
            latency_ms.push_back(static_cast<double>(last - ns) * 1e-6);
        }
        const bench::Summary s = bench::summarize(latency_ms);
        std::printf(
            "load_viewers: %zu ops, sent -> received by every viewer of %zu processes: p50 %.2f "
            "ms, p99 %.2f ms, max %.2f ms (%zu missing)\n",
            s.n, receipts.size(), s.p50, s.p99, s.max, missing);
        return missing == 0 ? 0 : 1;
    }

    asio::io_context io(1);
    Shared shared;
    shared.until = until;
    shared.last_ns.assign(static_cast<std::size_t>(until) + 1, 0);
    std::vector<std::unique_ptr<Viewer>> all;
    for (int i = 0; i < viewers; ++i)
        all.push_back(std::make_unique<Viewer>(io, port, token, shared));
    const auto start = std::chrono::steady_clock::now();
    while (shared.done + shared.failed < viewers &&
           std::chrono::steady_clock::now() - start < std::chrono::duration<double>(timeout))
        io.run_for(std::chrono::milliseconds(10));
    std::ofstream file(out);
    for (std::uint64_t seq = 1; seq <= until; ++seq)
        if (shared.last_ns[seq] != 0)
            file << seq << ' ' << shared.last_ns[seq] << '\n';
    std::printf(
        "load_viewers: %d viewers, %d reached seq %llu, %d failed\n", viewers, shared.done,
        static_cast<unsigned long long>(until), shared.failed);
    return shared.failed == 0 && shared.done == viewers ? 0 : 1;
}
