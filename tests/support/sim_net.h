#pragma once

// A deterministic simulated network for the protocol machines: the server's hub and session
// machines, and client machines, back to back with no sockets and no threads. Virtual time and
// one event queue ordered by (time, insertion), so a run is a pure function of its inputs. Each
// link has a latency, a bandwidth (a sender's bytes leave one after another), optional stalls,
// and can be cut at any event. The hub's commit and snapshot jobs run when they are submitted
// and their completions after a set delay, as if on their threads.

#include <terrain/client/client_machine.h>
#include <terrain/client/replica.h>
#include <terrain/server/authority.h>
#include <terrain/server/hub_host.h>
#include <terrain/server/server_hub.h>
#include <terrain/server/session_machine.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace terrain::testing {

/// Virtual time, the event queue, and the hub's host.
class SimWorld : public server::HubHost {
  public:
    double now = 0.0;
    double commit_delay = 0.002;   ///< a group commit's write + fdatasync
    double snapshot_delay = 0.010; ///< a join snapshot build
    bool accepting = true;

    /// Runs `fn` at time `t` (not before now), after every event already set for that time.
    void at(double t, std::function<void()> fn) {
        events_.emplace(Key{std::max(t, now), next_++}, std::move(fn));
    }
    void post(std::function<void()> fn) override { at(now, std::move(fn)); }
    void runCommit(Job job) override { at(now + commit_delay, job()); }
    void runSnapshot(Job job) override { at(now + snapshot_delay, job()); }
    void stopAccepting() override { accepting = false; }
    std::int64_t unixSeconds() const override {
        return 1'800'000'000 + static_cast<std::int64_t>(now);
    }
    /// Not printed: a run cuts links hundreds of times.
    void log(const server::LogEvent&) override {}

    /// Runs the earliest event; false when none is left.
    bool step() {
        if (events_.empty())
            return false;
        auto it = events_.begin();
        now = it->first.time;
        std::function<void()> fn = std::move(it->second);
        events_.erase(it);
        fn();
        ++steps;
        return true;
    }
    /// Runs events until `done()` or virtual time passes `until`; returns done().
    bool runUntil(const std::function<bool()>& done, double until) {
        while (!done()) {
            if (events_.empty() || events_.begin()->first.time > until)
                return done();
            step();
        }
        return true;
    }
    /// Runs every event up to time `t`, then sets the clock to `t`.
    void runTo(double t) {
        while (!events_.empty() && events_.begin()->first.time <= t)
            step();
        now = std::max(now, t);
    }
    std::uint64_t steps = 0;

  private:
    struct Key {
        double time;
        std::uint64_t order;
        bool operator<(const Key& o) const {
            return time < o.time || (time == o.time && order < o.order);
        }
    };
    std::map<Key, std::function<void()>> events_;
    std::uint64_t next_ = 0;
};

struct LinkSpec {
    double latency = 0.02;           ///< one way, seconds
    double bytes_per_second = 2.5e6; ///< 20 Mbit/s
    double stall_from = 0.0;         ///< no byte leaves either side in [stall_from, stall_to)
    double stall_to = 0.0;
};

/// One direction of a link: bytes leave one after another at the bandwidth, arrive after the
/// latency, in order.
class SimPipe {
  public:
    SimPipe(SimWorld& world, const LinkSpec& spec) : world_(world), spec_(spec) {}
    /// When `bytes` sent now have left the sender.
    double leave(std::size_t n) {
        double start = std::max(world_.now, busy_until_);
        if (start >= spec_.stall_from && start < spec_.stall_to)
            start = spec_.stall_to;
        double end = start + static_cast<double>(n) / spec_.bytes_per_second;
        if (start < spec_.stall_from && end > spec_.stall_from)
            end += spec_.stall_to - spec_.stall_from;
        busy_until_ = end;
        return end;
    }
    /// When they arrive.
    double arrive(double left) const { return left + spec_.latency; }
    /// When a close sent now arrives (after every byte sent before it).
    double closeArrives() const { return std::max(world_.now, busy_until_) + spec_.latency; }
    std::uint64_t sent = 0; ///< bytes

  private:
    SimWorld& world_;
    const LinkSpec& spec_;
    double busy_until_ = 0.0;
};

/// A client: a replica and its machine, linked to the hub through a simulated link, which it
/// opens again after a drop (like Connection's reconnect).
class SimClient : private server::SessionLink {
  public:
    SimClient(
        SimWorld& world,
        server::ServerHub& hub,
        client::ConnectionConfig config,
        LinkSpec spec = {},
        std::string name = "client")
        : machine(config, replica), world_(world), hub_(hub), spec_(spec), name_(std::move(name)),
          reconnect_delay_(config.reconnect_delay_seconds), reconnect_(config.reconnect) {
        machine.on_deform_reply = [this](const client::DeformAnswer& a) { answers.push_back(a); };
    }
    ~SimClient() override {
        if (session_)
            session_->attach(nullptr);
    }

    client::Replica replica;
    client::ClientMachine machine;
    std::vector<client::DeformAnswer> answers;
    std::vector<std::string> drops; ///< why each link ended, in order
    std::uint64_t deliveries = 0;   ///< delivery events on this client's links, both ways
    /// Cut the link at this delivery (0: never); counted by `deliveries`.
    std::uint64_t cut_at_delivery = 0;
    /// XOR-folded digest of every byte delivered to this client, in order (determinism).
    std::uint64_t digest = 1469598103934665603ull;
    bool linked() const { return session_ != nullptr; }

    void connect() {
        const std::uint64_t gen = ++generation_;
        down_ = std::make_unique<SimPipe>(world_, spec_);
        up_ = std::make_unique<SimPipe>(world_, spec_);
        writing_ = false;
        // the SYN and SYN-ACK: a round trip before the client may speak
        world_.at(world_.now + spec_.latency, [this, gen] {
            if (gen != generation_ || !world_.accepting)
                return;
            reading_ = true;
            session_ = hub_.addSession(name_, world_.now, this);
            world_.at(world_.now + spec_.latency, [this, gen] {
                if (gen != generation_)
                    return;
                machine.linkUp();
                flushClient(gen);
            });
        });
    }

    /// Client-side calls go through here so that what they queue is sent.
    template <typename F> auto call(F f) -> decltype(f()) {
        if constexpr (std::is_void_v<decltype(f())>) {
            f();
            flushClient(generation_);
        } else {
            auto r = f();
            flushClient(generation_);
            return r;
        }
    }
    /// Cuts the link now, as a network failure: each side learns it once what is in flight to
    /// it has arrived; the client reconnects after its delay.
    void cut(const std::string& why) {
        ++generation_;
        drops.push_back(why);
        machine.linkDown();
        if (auto session = session_) {
            session_.reset();
            session->attach(nullptr);
            world_.at(up_->closeArrives(), [session] { session->linkLost(); });
        }
        if (reconnect_)
            world_.at(world_.now + reconnect_delay_, [this] { connect(); });
    }

  private:
    void framesQueued() override { writeServer(generation_); }
    void setDeadline(double at) override {
        const std::uint64_t token = ++timer_token_;
        if (std::isinf(at))
            return;
        world_.at(at, [this, token] {
            if (token == timer_token_ && session_)
                session_->tick(world_.now);
        });
    }
    void stopReading() override { reading_ = false; }
    void closeLink() override {
        // the server closed: the client sees the end after everything sent before it
        auto session = std::move(session_);
        session_.reset();
        const std::uint64_t gen = generation_;
        world_.at(down_->closeArrives(), [this, gen] {
            if (gen != generation_)
                return;
            ++generation_;
            drops.push_back(
                machine.lastDisconnect().empty() ? "closed by the server"
                                                 : machine.lastDisconnect());
            machine.linkDown();
            if (reconnect_ && !machine.drop())
                world_.at(world_.now + reconnect_delay_, [this] { connect(); });
        });
    }

    void writeServer(std::uint64_t gen) {
        if (!session_ || writing_)
            return;
        const std::size_t n = session_->beginWrite(64 << 10);
        if (n == 0)
            return;
        std::vector<std::uint8_t> bytes;
        for (std::size_t i = 0; i < n; ++i) {
            const wire::Frame& f = session_->outbound().at(i).frame;
            bytes.insert(bytes.end(), f->begin(), f->end());
        }
        writing_ = true;
        down_->sent += bytes.size();
        const double left = down_->leave(bytes.size());
        auto session = session_;
        // the write completes once the bytes have left (the socket buffer is small)
        world_.at(left, [this, gen, session] {
            if (gen != generation_)
                return;
            writing_ = false;
            if (session == session_)
                session->endWrite(true);
        });
        world_.at(down_->arrive(left), [this, gen, bytes = std::move(bytes)] {
            if (gen != generation_)
                return;
            if (deliver())
                return;
            for (std::uint8_t b : bytes)
                digest = (digest ^ b) * 1099511628211ull;
            machine.receive(bytes, static_cast<std::uint64_t>(world_.now * 1e9));
            afterClient(gen);
        });
    }

    void flushClient(std::uint64_t gen) {
        if (gen != generation_ || machine.output().empty())
            return;
        std::vector<std::uint8_t> bytes;
        bytes.swap(machine.output());
        up_->sent += bytes.size();
        const double when = up_->arrive(up_->leave(bytes.size()));
        world_.at(when, [this, gen, bytes = std::move(bytes)] {
            if (gen != generation_ || !session_)
                return;
            if (deliver())
                return;
            if (reading_)
                session_->receive(bytes, world_.now);
        });
    }

    /// After the client machine ran: a drop it asked for, or what it queued.
    void afterClient(std::uint64_t gen) {
        if (gen != generation_)
            return;
        if (const auto& d = machine.drop()) {
            const bool final_reason = d->final;
            const std::string why = d->why;
            const bool keep = reconnect_;
            reconnect_ = reconnect_ && !final_reason;
            cut(why);
            reconnect_ = keep;
            return;
        }
        flushClient(gen);
    }

    /// Counts a delivery; true when this one cuts the link instead.
    bool deliver() {
        ++deliveries;
        if (cut_at_delivery != 0 && deliveries == cut_at_delivery) {
            cut("cut by the test at delivery " + std::to_string(deliveries));
            return true;
        }
        return false;
    }

    SimWorld& world_;
    server::ServerHub& hub_;
    LinkSpec spec_;
    std::string name_;
    double reconnect_delay_;
    bool reconnect_;
    std::shared_ptr<server::SessionMachine> session_;
    std::unique_ptr<SimPipe> down_; ///< server -> client
    std::unique_ptr<SimPipe> up_;   ///< client -> server
    std::uint64_t generation_ = 0;
    std::uint64_t timer_token_ = 0;
    bool writing_ = false;
    bool reading_ = false;
};

} // namespace terrain::testing
