#include <terrain/server/server_thread.h>

#include <asio.hpp>
#include <chrono>
#include <random>
#include <thread>

namespace terrain::server {

std::vector<std::uint8_t> randomTokenSecret() {
    std::random_device device;
    std::vector<std::uint8_t> secret(32);
    for (std::uint8_t& b : secret)
        b = static_cast<std::uint8_t>(device() & 0xffu);
    return secret;
}

struct ServerThread::Impl {
    // the io_context first: it outlives the server whose handlers it holds
    asio::io_context io{1};
    asio::executor_work_guard<asio::io_context::executor_type> work = asio::make_work_guard(io);
    std::unique_ptr<Authority> authority;
    std::unique_ptr<Server> server;
    double linger_seconds = 0.0;
    std::thread thread;
};

ServerThread::ServerThread(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Result<std::unique_ptr<ServerThread>>
ServerThread::start(Terrain terrain, ServerThreadOptions options) {
    auto impl = std::make_unique<Impl>();
    impl->authority = std::make_unique<Authority>(
        std::move(terrain), options.seq, options.config.op_log_capacity);
    if (options.prepare)
        options.prepare(*impl->authority);
    impl->linger_seconds = options.config.close_linger_seconds;
    // built and bound before the thread runs the loop, so nothing races with it
    impl->server = std::make_unique<Server>(
        impl->io, options.transport, options.config, *impl->authority, options.journal);
    if (options.log)
        impl->server->setLog(options.log);
    if (Status s = impl->server->start(); !s)
        return s.error();
    Impl* raw = impl.get();
    impl->thread = std::thread([raw] { raw->io.run(); });
    std::unique_ptr<ServerThread> t(new ServerThread(std::move(impl)));
    t->port_ = t->impl_->server->port();
    return t;
}

ServerThread::~ServerThread() {
    stop();
}

bool ServerThread::running() const {
    return impl_->thread.joinable();
}

void ServerThread::stop(double max_wait_seconds) {
    if (!impl_->thread.joinable())
        return;
    auto drained = std::make_shared<std::promise<void>>();
    std::future<void> done = drained->get_future();
    post([this, drained] { impl_->server->shutdown([drained] { drained->set_value(); }); });
    done.wait_for(std::chrono::duration<double>(
        max_wait_seconds < 0.0 ? impl_->linger_seconds + 1.0 : max_wait_seconds));
    // handlers still pending are dropped, not run; the server and its sessions are destroyed
    // with the Impl, before the io_context that holds their sockets
    impl_->work.reset();
    impl_->io.stop();
    impl_->thread.join();
}

void ServerThread::post(std::function<void()> f) {
    asio::post(impl_->io, std::move(f));
}

std::uint64_t ServerThread::seq() {
    return call([this] { return impl_->server->broadcastSeq(); });
}

std::uint64_t ServerThread::worldHash() {
    return call([this] { return impl_->authority->terrain().worldHash(); });
}

ServerStats ServerThread::stats() {
    return call([this] { return impl_->server->stats(); });
}

Authority& ServerThread::authority() {
    return *impl_->authority;
}
Server& ServerThread::server() {
    return *impl_->server;
}

} // namespace terrain::server
