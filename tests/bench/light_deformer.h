#pragma once

// A deformer without a replica, for benchmarks that load a real server process: Hello, then
// canonical DeformRequests; it reads the replies and skips everything else (the ops, batches).
// Shared by battle_feed --light and recovery_bench.

#include <terrain/client/connection.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>

#include <asio.hpp>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace terrain::bench {

/// A deformer without a replica: Hello, then requests; reads replies and skips everything else.
class LightDeformer {
  public:
    /// `name`: the client name sent in Hello and the prefix of the failure line on stderr
    /// (`quiet`: none, for benchmarks that kill the server on purpose).
    LightDeformer(
        asio::io_context& io,
        const std::string& host,
        std::uint16_t port,
        const std::string& token,
        std::string name = "battle_feed --light",
        bool quiet = false)
        : socket_(io), name_(std::move(name)), quiet_(quiet) {
        wire::pb::Envelope e;
        e.mutable_hello()->set_protocol_version(wire::kProtocolVersion);
        e.mutable_hello()->set_token(token);
        e.mutable_hello()->set_client_name(name_);
        wire::appendFrame(e, out_);
        socket_.async_connect(
            {asio::ip::make_address(host), port}, [this](const asio::error_code& ec) {
                if (ec)
                    return fail("connect: " + ec.message());
                socket_.set_option(asio::ip::tcp::no_delay(true));
                write();
                read();
            });
    }
    std::function<void(const client::DeformAnswer&)> on_reply;
    bool joined() const { return joined_ && !failed_; }
    bool failed() const { return failed_; }
    std::uint64_t opBytes() const { return op_bytes_; }
    std::uint32_t request(const DeformOp& op) {
        wire::pb::Envelope e;
        e.mutable_deform()->set_request_id(next_id_);
        wire::opToWire(op, *e.mutable_deform()->mutable_canonical());
        wire::appendFrame(e, out_);
        write();
        return next_id_++;
    }

  private:
    void fail(const std::string& why) {
        if (!failed_ && !quiet_)
            std::fprintf(stderr, "%s: %s\n", name_.c_str(), why.c_str());
        failed_ = true;
        asio::error_code ignored;
        socket_.close(ignored);
    }
    void write() {
        if (writing_ || out_.empty() || !socket_.is_open())
            return;
        writing_ = true;
        busy_.swap(out_);
        out_.clear();
        asio::async_write(socket_, asio::buffer(busy_), [this](const asio::error_code& ec, auto) {
            writing_ = false;
            if (ec)
                return fail("write: " + ec.message());
            write();
        });
    }
    void read() {
        const std::span<std::uint8_t> space = reader_.prepare(64 << 10);
        socket_.async_read_some(
            asio::buffer(space.data(), space.size()),
            [this](const asio::error_code& ec, std::size_t n) {
                if (ec)
                    return fail("read: " + ec.message());
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
                    if (e->has_welcome()) {
                        joined_ = true;
                    } else if (e->has_op_applied() || e->has_op_batch()) {
                        op_bytes_ += (*next)->size() + wire::framePrefixSize((*next)->size());
                    } else if (e->has_deform_reply() && on_reply) {
                        const auto& r = e->deform_reply();
                        client::DeformAnswer a;
                        a.request_id = r.request_id();
                        a.accepted = r.result_case() == wire::pb::DeformReply::kAcceptedSeq;
                        a.seq = r.accepted_seq();
                        on_reply(a);
                    } else if (e->has_disconnect()) {
                        return fail("disconnected: " + e->disconnect().message());
                    }
                }
                read();
            });
    }

    asio::ip::tcp::socket socket_;
    std::string name_;
    bool quiet_ = false;
    wire::FrameReader reader_{std::size_t{64} << 20};
    std::vector<std::uint8_t> out_;
    std::vector<std::uint8_t> busy_;
    bool writing_ = false;
    bool joined_ = false;
    bool failed_ = false;
    std::uint32_t next_id_ = 1;
    std::uint64_t op_bytes_ = 0;
};

} // namespace terrain::bench
