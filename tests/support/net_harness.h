#pragma once

// Loopback harness: a real Server on its own io thread, clients on the test thread's io_context,
// raw sockets for misbehaving peers. Everything goes through real TCP on 127.0.0.1.

#include "support/loopback.h"
#include "support/terrain_builders.h"

#include <terrain/client/connection.h>
#include <terrain/client/replica.h>
#include <terrain/procedural_map.h>
#include <terrain/server/auth_token.h>
#include <terrain/server/authority.h>
#include <terrain/server/server.h>
#include <terrain/server/server_thread.h>
#include <terrain/wire/codec.h>
#include <terrain/wire/framing.h>

#include <gtest/gtest.h>

#include <asio.hpp>
#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace terrain::testing {

/// A server on its own thread (server::ServerThread) with the test token secret.
class TestServer {
  public:
    explicit TestServer(
        Terrain terrain,
        server::ServerConfig config = {},
        journal::Journal* journal = nullptr,
        std::uint64_t seq = 0,
        server::TransportConfig transport = {}) {
        config.token_secret = testSecret();
        server::ServerThreadOptions options;
        options.transport = std::move(transport);
        options.config = std::move(config);
        options.seq = seq;
        options.journal = journal;
        auto started = server::ServerThread::start(std::move(terrain), std::move(options));
        EXPECT_TRUE(started.ok()) << (started ? "" : started.error().message);
        if (started)
            thread_ = std::move(*started);
    }
    ~TestServer() { stop(); }

    template <typename F> auto call(F f) -> decltype(f()) { return thread_->call(std::move(f)); }

    /// Shuts down, gives sessions 50 ms for their goodbye (the test's clients may not be
    /// reading), then stops the loop.
    void stop() {
        if (thread_)
            thread_->stop(0.05);
    }

    std::uint16_t port() const { return thread_->port(); }
    std::uint64_t seq() { return thread_->seq(); }
    std::uint64_t worldHash() { return thread_->worldHash(); }
    server::ServerStats stats() { return thread_->stats(); }
    server::Authority& authority() { return thread_->authority(); } // server thread only (call())
    server::Server& server() { return thread_->server(); }          // server thread only (call())

  private:
    std::unique_ptr<server::ServerThread> thread_;
};

/// A client: replica + connection on the test thread's io_context.
struct TestClient {
    client::Replica replica;
    std::shared_ptr<client::Connection> connection;
    std::vector<client::DeformAnswer> answers;
    std::vector<std::string> disconnects;

    TestClient(
        asio::io_context& io,
        std::uint16_t port,
        std::string tok,
        bool reconnect = true,
        client::OpPacing pacing = {},
        std::optional<Terrain> genesis = std::nullopt) {
        if (genesis) { // the map this client ships with
            EXPECT_TRUE(replica.loadGenesis(std::move(*genesis)).ok());
        }
        client::ConnectionConfig config;
        config.port = port;
        config.pacing = pacing;
        config.token = std::move(tok);
        config.reconnect = reconnect;
        config.reconnect_delay_seconds = 0.05;
        connection = std::make_shared<client::Connection>(io, config, replica);
        connection->on_deform_reply = [this](const client::DeformAnswer& a) {
            answers.push_back(a);
        };
        connection->on_disconnect = [this](const std::string& why) { disconnects.push_back(why); };
        connection->start();
    }
    ~TestClient() { connection->stop(); }
};

/// Runs `io` until `done()` or the timeout; returns done().
inline bool
runUntil(asio::io_context& io, const std::function<bool()>& done, double timeout_seconds = 20.0) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(timeout_seconds));
    while (!done()) {
        if (std::chrono::steady_clock::now() > deadline)
            return false;
        io.restart();
        io.run_for(std::chrono::milliseconds(5));
    }
    return true;
}

/// A blocking raw TCP peer for protocol abuse tests.
class RawPeer {
  public:
    /// `from`: a loopback source address (127.0.0.2, ...) so that a test can stand for peers
    /// at several addresses.
    explicit RawPeer(std::uint16_t port, int receive_buffer = 0, const char* from = nullptr)
        : socket_(io_) {
        socket_.open(asio::ip::tcp::v4());
        if (receive_buffer > 0)
            socket_.set_option(asio::socket_base::receive_buffer_size(receive_buffer));
        if (from != nullptr)
            socket_.bind({asio::ip::make_address(from), 0});
        socket_.connect({asio::ip::make_address("127.0.0.1"), port});
    }
    void sendBytes(const std::vector<std::uint8_t>& bytes) {
        asio::error_code ec;
        asio::write(socket_, asio::buffer(bytes), ec);
    }
    void send(const wire::pb::Envelope& envelope) {
        std::vector<std::uint8_t> bytes;
        wire::appendFrame(envelope, bytes);
        sendBytes(bytes);
    }
    void sendHello(const std::string& tok, std::uint32_t version = wire::kProtocolVersion) {
        wire::pb::Envelope e;
        e.mutable_hello()->set_protocol_version(version);
        e.mutable_hello()->set_token(tok);
        send(e);
    }
    /// Reads frames until a Disconnect (its reason) or EOF/timeout (REASON_UNSPECIFIED).
    wire::pb::Reason
    readUntilDisconnect(double timeout_seconds = 10.0, std::string* message = nullptr) {
        wire::FrameReader reader(64 << 20);
        const auto deadline = std::chrono::steady_clock::now() +
                              std::chrono::milliseconds(static_cast<int>(timeout_seconds * 1000));
        socket_.non_blocking(true);
        while (std::chrono::steady_clock::now() < deadline) {
            auto space = reader.prepare(1 << 16);
            asio::error_code ec;
            const std::size_t n = socket_.read_some(asio::buffer(space.data(), space.size()), ec);
            if (ec == asio::error::would_block) {
                std::this_thread::sleep_for(std::chrono::milliseconds(2));
                continue;
            }
            if (ec)
                return wire::pb::REASON_UNSPECIFIED;
            reader.commit(n);
            for (;;) {
                auto frame = reader.next();
                if (!frame || !frame->has_value())
                    break;
                auto env = wire::decodeEnvelope(**frame);
                if (env && env->has_disconnect()) {
                    if (message)
                        *message = env->disconnect().message();
                    return env->disconnect().reason();
                }
                if (env) {
                    received.push_back(env->body_case());
                    envelopes.push_back(*env);
                }
            }
        }
        return wire::pb::REASON_UNSPECIFIED;
    }
    /// True when the server closed the connection (EOF) within the timeout.
    bool closedByServer(double timeout_seconds = 10.0) {
        return readUntilDisconnect(timeout_seconds) != wire::pb::REASON_UNSPECIFIED || eofSeen();
    }
    bool eofSeen() {
        asio::error_code ec;
        std::uint8_t b;
        socket_.non_blocking(true);
        socket_.read_some(asio::buffer(&b, 1), ec);
        return ec == asio::error::eof || ec == asio::error::connection_reset;
    }
    std::vector<int> received;                 ///< body cases, in order
    std::vector<wire::pb::Envelope> envelopes; ///< the same frames, decoded

  private:
    asio::io_context io_;
    asio::ip::tcp::socket socket_;
};

} // namespace terrain::testing
