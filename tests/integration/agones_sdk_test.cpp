// The Agones SDK calls against a stand-in for the SDK sidecar's HTTP gateway: a real
// terrain-server process with --agones says Ready (retried while the sidecar refuses), pings
// Health, and says Shutdown after its SIGTERM drain; in process, pings stop while the server
// is unhealthy and resume after.

#include "support/net_harness.h"
#include "support/server_process.h"

#include <terrain/server/agones_sdk.h>

#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

namespace terrain::testing {
namespace {

namespace fs = std::filesystem;

/// The sidecar's HTTP gateway as far as the SDK's lifecycle calls go: records each request and
/// answers 200, except the first `refuse_ready` POST /ready (503: not up yet).
class FakeSidecar {
  public:
    struct Request {
        std::string method, path, content_type, body;
    };

    explicit FakeSidecar(int refuse_ready = 0)
        : acceptor_(io_, {asio::ip::make_address("127.0.0.1"), 0}), refuse_ready_(refuse_ready) {
        accept();
        thread_ = std::thread([this] { io_.run(); });
    }
    ~FakeSidecar() {
        io_.stop();
        thread_.join();
    }
    std::uint16_t port() const { return acceptor_.local_endpoint().port(); }
    std::vector<Request> requests() const {
        std::lock_guard lock(mutex_);
        return requests_;
    }
    std::size_t count(const std::string& path) const {
        std::size_t n = 0;
        for (const Request& r : requests())
            n += r.path == path ? 1 : 0;
        return n;
    }

  private:
    void accept() {
        acceptor_.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket socket) {
            if (ec)
                return;
            serve(std::make_shared<asio::ip::tcp::socket>(std::move(socket)));
            accept();
        });
    }
    void serve(std::shared_ptr<asio::ip::tcp::socket> socket) {
        auto buffer = std::make_shared<asio::streambuf>();
        asio::async_read_until(
            *socket, *buffer, "\r\n\r\n",
            [this, socket, buffer](const asio::error_code& ec, std::size_t head_bytes) {
                if (ec)
                    return;
                std::string head(
                    asio::buffers_begin(buffer->data()),
                    asio::buffers_begin(buffer->data()) + static_cast<long>(head_bytes));
                buffer->consume(head_bytes);
                Request r;
                std::istringstream lines(head);
                lines >> r.method >> r.path;
                std::size_t length = 0;
                for (std::string line; std::getline(lines, line);) {
                    if (line.rfind("Content-Length: ", 0) == 0)
                        length = std::stoul(line.substr(16));
                    if (line.rfind("Content-Type: ", 0) == 0)
                        r.content_type = line.substr(14, line.find('\r') - 14);
                }
                asio::error_code read_ec;
                if (buffer->size() < length)
                    asio::read(
                        *socket, *buffer, asio::transfer_exactly(length - buffer->size()), read_ec);
                r.body.assign(
                    asio::buffers_begin(buffer->data()),
                    asio::buffers_begin(buffer->data()) + static_cast<long>(length));
                bool refuse = false;
                {
                    std::lock_guard lock(mutex_);
                    if (r.path == "/ready" && refuse_ready_ > 0) {
                        --refuse_ready_;
                        refuse = true;
                        r.path = "/ready (refused)";
                    }
                    requests_.push_back(r);
                }
                const std::string answer =
                    refuse ? "HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\n\r\n"
                           : "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n"
                             "Content-Length: 2\r\n\r\n{}";
                asio::write(*socket, asio::buffer(answer), read_ec);
                socket->close(read_ec);
            });
    }

    asio::io_context io_;
    asio::ip::tcp::acceptor acceptor_;
    std::thread thread_;
    mutable std::mutex mutex_;
    std::vector<Request> requests_;
    int refuse_ready_;
};

bool waitFor(const std::function<bool()>& done, double seconds) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!done()) {
        if (std::chrono::steady_clock::now() > until)
            return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
}

TEST(AgonesSdk, ServerSaysReadyPingsHealthAndSaysShutdownAfterItsDrain) {
    FakeSidecar sidecar(1);
    const fs::path dir = fs::temp_directory_path() / ("terrain-agones-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string log = (dir / "server.log").string();
    const pid_t pid = spawnServerProcess(
        {"--port-file", (dir / "port").string(), "--no-journal", "--size", "129", "--log-format",
         "json", "--agones", "--agones-sdk-port", std::to_string(sidecar.port()),
         "--agones-health-ms", "100"},
        log);
    ASSERT_GT(pid, 0);
    const bool pinged = waitFor([&] { return sidecar.count("/health") >= 3; }, 20.0);
    ::kill(pid, SIGTERM);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(pinged) << "no Ready and three health pings; see " << log;
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "see " << log;

    const std::vector<FakeSidecar::Request> calls = sidecar.requests();
    ASSERT_GE(calls.size(), 6u);
    // the sidecar was not up at first: the refusal, then Ready again before any ping
    EXPECT_EQ(calls[0].path, "/ready (refused)");
    EXPECT_EQ(calls[1].path, "/ready");
    for (std::size_t i = 2; i + 1 < calls.size(); ++i)
        EXPECT_EQ(calls[i].path, "/health") << "call " << i;
    // Shutdown once, last, after the drain
    EXPECT_EQ(calls.back().path, "/shutdown");
    for (const FakeSidecar::Request& r : calls) {
        EXPECT_EQ(r.method, "POST");
        EXPECT_EQ(r.content_type, "application/json");
        EXPECT_EQ(r.body, "{}");
    }
    std::ifstream in(log);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("\"event\":\"agones.ready\""), std::string::npos) << text;
    EXPECT_NE(text.find("\"event\":\"agones.shutdown\""), std::string::npos) << text;
    EXPECT_NE(text.find("Agones acknowledged Shutdown"), std::string::npos) << text;
    fs::remove_all(dir);
}

TEST(AgonesSdk, NoHealthPingWhileUnhealthyAndShutdownEndsEvenWithoutASidecar) {
    FakeSidecar sidecar;
    asio::io_context io;
    bool healthy = true;
    server::AgonesSdk::Options options;
    options.port = sidecar.port();
    options.health_every = std::chrono::milliseconds(20);
    server::AgonesSdk sdk(
        io, options, [&] { return healthy; }, nullptr);
    sdk.start();
    ASSERT_TRUE(runUntil(io, [&] { return sdk.healthPingsAcknowledged() >= 3; }));
    EXPECT_TRUE(sdk.readyAcknowledged());

    healthy = false; // draining or a failed journal: Agones must see the pings stop
    io.run_for(std::chrono::milliseconds(60)); // a ping already on the wire lands
    const std::uint64_t acked = sdk.healthPingsAcknowledged();
    const std::size_t seen = sidecar.count("/health");
    io.run_for(std::chrono::milliseconds(300));
    EXPECT_EQ(sdk.healthPingsAcknowledged(), acked);
    EXPECT_EQ(sidecar.count("/health"), seen);

    healthy = true;
    ASSERT_TRUE(runUntil(io, [&] { return sdk.healthPingsAcknowledged() >= acked + 2; }));

    // no sidecar at all (a plain container run with --agones by mistake): Shutdown gives up
    // after its timeout and the drain still ends
    server::AgonesSdk::Options nowhere = options;
    {
        asio::io_context probe;
        asio::ip::tcp::acceptor closed(probe, {asio::ip::make_address("127.0.0.1"), 0});
        nowhere.port = closed.local_endpoint().port();
    } // the port is free again: nothing listens there
    nowhere.call_timeout = std::chrono::milliseconds(300);
    server::AgonesSdk orphan(
        io, nowhere, [] { return true; }, nullptr);
    bool done = false;
    orphan.shutdown([&] { done = true; });
    ASSERT_TRUE(runUntil(
        io, [&] { return done; }, 5.0));
    EXPECT_FALSE(orphan.readyAcknowledged());
}

} // namespace
} // namespace terrain::testing
