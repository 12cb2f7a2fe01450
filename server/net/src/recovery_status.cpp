#include "status_http.h"

#include <terrain/server/recovery_status.h>

#include <thread>

namespace terrain::server {

struct RecoveryStatus::Impl {
    asio::io_context io{1};
    StatusHttp http{io, [](std::string_view path) -> HttpResponse {
                        if (path == "/livez")
                            return {200, "text/plain; charset=utf-8", "alive\n"};
                        if (path == "/readyz" || path == "/metrics")
                            return {
                                503, "text/plain; charset=utf-8",
                                "recovering: the journal is being replayed\n"};
                        return {
                            404, "text/plain; charset=utf-8",
                            "no such page: /metrics, /livez and /readyz\n"};
                    }};
    std::thread thread;
};

RecoveryStatus::RecoveryStatus(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Result<std::unique_ptr<RecoveryStatus>>
RecoveryStatus::start(const std::string& address, std::uint16_t port) {
    auto impl = std::make_unique<Impl>();
    if (Status s = impl->http.listen(address, port); !s)
        return s.error();
    Impl* raw = impl.get();
    raw->thread = std::thread([raw] {
        auto work = asio::make_work_guard(raw->io);
        raw->io.run();
    });
    return std::unique_ptr<RecoveryStatus>(new RecoveryStatus(std::move(impl)));
}

RecoveryStatus::~RecoveryStatus() {
    stop();
}

std::uint16_t RecoveryStatus::port() const {
    return impl_->http.port();
}

void RecoveryStatus::stop() {
    if (!impl_->thread.joinable())
        return;
    // closing the acceptor on its own thread ends its accept; then the loop may stop
    asio::post(impl_->io, [this] {
        impl_->http.close();
        impl_->io.stop();
    });
    impl_->thread.join();
}

} // namespace terrain::server
