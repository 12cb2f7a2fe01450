#include "network_thread.h"

#include <terrain/client/connection.h>

#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

namespace terrain::game::detail {

struct NetworkThread::State {
    asio::io_context io;
    client::Replica replica; // the network thread's: every op checked here
    std::shared_ptr<client::Connection> connection;
    std::map<std::uint32_t, std::uint32_t> request_ids; // the connection's id -> ours
    std::atomic<bool> stopping{false};
    std::thread thread;

    std::mutex mutex; // guards the members below
    NetworkNews news;
    std::uint32_t next_id = 0;

    // Network thread: hands what happened to the frame thread's side of the lock.
    void publish() {
        std::vector<client::ReplicaChange> changes = replica.takeChanges();
        replica.takeDirty(); // nothing draws this copy
        const bool live = connection->state() == client::Connection::State::kLive;
        const std::lock_guard<std::mutex> lock(mutex);
        for (client::ReplicaChange& c : changes)
            news.changes.push_back(std::move(c));
        news.live = live;
        news.synced = connection->synced();
        news.closed = connection->state() == client::Connection::State::kClosed;
        news.last_disconnect = connection->lastDisconnect();
        news.stats = replica.stats();
        news.seq = replica.seq();
    }

    void answer(std::uint32_t id, bool accepted, std::uint64_t seq, std::string reason) {
        const std::lock_guard<std::mutex> lock(mutex);
        news.answers.push_back({id, accepted, seq, std::move(reason)});
    }

    void run() {
        // ops are applied as they are read (unpaced): the frame thread paces its own replays
        while (!stopping.load(std::memory_order_acquire)) {
            io.run_for(std::chrono::milliseconds(2));
            publish();
            if (io.stopped()) { // nothing left to wait for (closed): idle until stopped
                io.restart();
                std::this_thread::sleep_for(std::chrono::milliseconds(2));
            }
        }
        connection->stop();
        io.restart();
        io.poll(); // the cancelled handlers run (they hold the connection)
        publish();
    }
};

NetworkThread::NetworkThread(client::ConnectionConfig config) : state_(std::make_unique<State>()) {
    State& s = *state_;
    config.pacing = {};
    s.replica.recordChanges(true);
    s.connection = std::make_shared<client::Connection>(s.io, std::move(config), s.replica);
    s.connection->on_deform_reply = [&s](const client::DeformAnswer& a) {
        const auto it = s.request_ids.find(a.request_id);
        if (it == s.request_ids.end())
            return;
        s.answer(it->second, a.accepted, a.seq, a.reason);
        s.request_ids.erase(it);
    };
    s.connection->start();
    s.thread = std::thread([&s] { s.run(); });
}

NetworkThread::~NetworkThread() {
    stop();
}

NetworkNews NetworkThread::take() {
    State& s = *state_;
    const std::lock_guard<std::mutex> lock(s.mutex);
    NetworkNews out = std::move(s.news);
    s.news = NetworkNews{};
    // the state flags are the latest, not news: they stay
    s.news.live = out.live;
    s.news.synced = out.synced;
    s.news.closed = out.closed;
    s.news.last_disconnect = out.last_disconnect;
    s.news.stats = out.stats;
    s.news.seq = out.seq;
    return out;
}

std::uint32_t NetworkThread::requestDeform(const OpRequest& request) {
    State& s = *state_;
    std::uint32_t id = 0;
    {
        const std::lock_guard<std::mutex> lock(s.mutex);
        id = ++s.next_id;
    }
    asio::post(s.io, [&s, id, request] {
        const std::uint32_t sent = s.connection->requestDeform(request);
        if (sent == 0)
            s.answer(id, false, 0, s.connection->lastRefusal());
        else
            s.request_ids[sent] = id;
    });
    return id;
}

void NetworkThread::stop() {
    State& s = *state_;
    if (!s.thread.joinable())
        return;
    s.stopping.store(true, std::memory_order_release);
    s.io.stop(); // wakes run_for
    s.thread.join();
}

} // namespace terrain::game::detail
