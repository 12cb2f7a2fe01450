#include <terrain/server/auth_token.h>
#include <terrain/server/authority.h>
#include <terrain/server/server.h>
#include <terrain/server/server_thread.h>
#include <terrain/viewer/in_process_server.h>

#include <chrono>
#include <vector>

namespace terrain::viewer {

struct InProcessServer::Impl {
    std::unique_ptr<server::ServerThread> thread;
};

InProcessServer::InProcessServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Result<std::unique_ptr<InProcessServer>> InProcessServer::start(Terrain terrain) {
    server::ServerThreadOptions options;
    options.transport.bind_address = "127.0.0.1";
    options.transport.port = 0;
    options.config.token_secret = server::randomTokenSecret();
    const std::vector<std::uint8_t> secret = options.config.token_secret;
    auto thread = server::ServerThread::start(std::move(terrain), std::move(options));
    if (!thread)
        return thread.error();
    const std::int64_t now = std::chrono::duration_cast<std::chrono::seconds>(
                                 std::chrono::system_clock::now().time_since_epoch())
                                 .count();
    auto impl = std::make_unique<Impl>();
    impl->thread = std::move(*thread);
    std::unique_ptr<InProcessServer> s(new InProcessServer(std::move(impl)));
    s->token_ = server::mintToken({1, server::Role::kDeformer, now + 24 * 3600}, secret);
    return s;
}

InProcessServer::~InProcessServer() {
    // the sessions get their goodbye (bounded by the server's linger time), then the thread stops
    impl_->thread->stop(3.0);
}

std::uint16_t InProcessServer::port() const {
    return impl_->thread->port();
}

InProcessServer::State InProcessServer::state() {
    server::ServerThread& t = *impl_->thread;
    return t.call([&t] {
        const server::ServerStats& st = t.server().stats();
        return State{
            t.server().broadcastSeq(), t.authority().terrain().worldHash(), st.ops_accepted,
            st.ops_refused};
    });
}

} // namespace terrain::viewer
