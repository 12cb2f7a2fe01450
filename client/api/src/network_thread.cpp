#include "network_thread.h"

#include <terrain/client/connection.h>

#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <utility>

namespace terrain::game::detail {

struct NetworkThread::State {
    // the replica first: the io_context's pending handlers hold the connection, which holds a
    // reference to it, until the io_context is gone
    client::Replica replica; // the network thread's: every op checked here
    asio::io_context io;
    std::shared_ptr<client::Connection> connection;
    std::map<std::uint32_t, std::uint32_t> request_ids; // the connection's id -> ours
    std::atomic<bool> stopping{false};
    std::thread thread;

    std::vector<std::uint64_t> synced_versions; // the tiles as the frame's copy will hold them

    std::mutex mutex; // guards the members below
    NetworkNews news;
    std::uint32_t next_id = 0;

    // Network thread: hands what happened to the frame thread's side of the lock.
    void publish() {
        std::vector<client::ReplicaChange> changes = replica.takeChanges();
        replica.takeDirty(); // nothing draws this copy
        client::ReplicaSync sync;
        if (!changes.empty())
            sync = replica.takeSync(synced_versions, std::move(changes));
        const bool live = connection->state() == client::Connection::State::kLive;
        if (!live)
            request_ids.clear(); // sent on a link now lost: no answer comes (as pump()'s mode)
        const std::lock_guard<std::mutex> lock(mutex);
        if (!sync.empty())
            news.syncs.push_back(std::move(sync));
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
        try {
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
        } catch (const std::exception& e) {
            fault(e.what());
        } catch (...) {
            fault("an unknown exception");
        }
    }

    // Something threw on this thread (out of memory in a snapshot, a bug): the client closes
    // with the reason, as pump() would have said it, instead of the process ending.
    void fault(const char* what) noexcept {
        try {
            {
                const std::lock_guard<std::mutex> lock(mutex);
                news.closed = true;
                news.live = false;
                news.synced = false;
                news.last_disconnect = std::string("INTERNAL: network thread: ") + what;
            }
            connection->stop();
            io.restart();
            io.poll();
        } catch (...) {
            const std::lock_guard<std::mutex> lock(mutex);
            news.closed = true; // the message could not be made; the close stands
        }
        while (!stopping.load(std::memory_order_acquire))
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
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

void NetworkThread::throwOnTheThreadForTesting(std::string what) {
    asio::post(state_->io, [what = std::move(what)] { throw std::runtime_error(what); });
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
