#include <terrain/server/auth_token.h>
#include <terrain/server/authority.h>
#include <terrain/server/server.h>
#include <terrain/viewer/in_process_server.h>

#include <asio.hpp>
#include <chrono>
#include <future>
#include <random>
#include <thread>
#include <vector>

namespace terrain::viewer {

namespace {
std::vector<std::uint8_t> randomSecret() {
    // nobody else ever needs this secret: it only has to be unguessable for this run
    std::random_device device;
    std::vector<std::uint8_t> secret(32);
    for (std::uint8_t& b : secret)
        b = static_cast<std::uint8_t>(device() & 0xffu);
    return secret;
}
} // namespace

struct InProcessServer::Impl {
    // the io_context first: it outlives the server whose handlers it holds
    asio::io_context io{1};
    asio::executor_work_guard<asio::io_context::executor_type> work = asio::make_work_guard(io);
    std::unique_ptr<server::Authority> authority;
    std::unique_ptr<server::Server> srv;
    std::thread thread;

    /// Runs `f` on the server thread and waits for its result.
    template <typename F> auto call(F f) -> decltype(f()) {
        std::packaged_task<decltype(f())()> task(std::move(f));
        auto result = task.get_future();
        asio::post(io, [&task] { task(); });
        return result.get();
    }
};

InProcessServer::InProcessServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Result<std::unique_ptr<InProcessServer>> InProcessServer::start(Terrain terrain) {
    auto impl = std::make_unique<Impl>();
    server::ServerConfig config;
    config.bind_address = "127.0.0.1";
    config.port = 0;
    config.token_secret = randomSecret();
    impl->authority =
        std::make_unique<server::Authority>(std::move(terrain), 0, config.op_log_capacity);
    // built and bound before the thread runs the loop, so nothing races with it
    impl->srv = std::make_unique<server::Server>(impl->io, config, *impl->authority, nullptr);
    if (Status s = impl->srv->start(); !s)
        return s.error();
    const std::int64_t now = std::chrono::duration_cast<std::chrono::seconds>(
                                 std::chrono::system_clock::now().time_since_epoch())
                                 .count();
    const std::string token =
        server::mintToken({1, server::Role::kDeformer, now + 24 * 3600}, config.token_secret);
    Impl* raw = impl.get();
    impl->thread = std::thread([raw] { raw->io.run(); });
    std::unique_ptr<InProcessServer> s(new InProcessServer(std::move(impl)));
    s->token_ = token;
    return s;
}

InProcessServer::~InProcessServer() {
    if (!impl_->thread.joinable())
        return;
    // say goodbye to the sessions, wait for them (bounded by the server's linger time), stop
    auto drained = std::make_shared<std::promise<void>>();
    std::future<void> done = drained->get_future();
    asio::post(
        impl_->io, [this, drained] { impl_->srv->shutdown([drained] { drained->set_value(); }); });
    done.wait_for(std::chrono::seconds(3));
    impl_->work.reset();
    impl_->io.stop();
    impl_->thread.join();
}

std::uint16_t InProcessServer::port() const {
    return impl_->srv->port(); // set once by start(), before the thread began
}

InProcessServer::State InProcessServer::state() {
    return impl_->call([this] {
        const server::ServerStats& st = impl_->srv->stats();
        return State{
            impl_->srv->broadcastSeq(), impl_->authority->terrain().worldHash(), st.ops_accepted,
            st.ops_refused};
    });
}

} // namespace terrain::viewer
