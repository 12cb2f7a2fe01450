#pragma once

// A session's outbound frames. Frames are shared (one encoding per op for every session), so
// the queue holds pointers; its budget counts the bytes that are this session's own backlog
// (ops and replies), not the shared snapshot frames it is streaming.

#include <terrain/wire/codec.h>

#include <cstddef>
#include <deque>

namespace terrain::server {

enum class FrameClass : unsigned char {
    kOp,       ///< an OpApplied broadcast: dropped on resync
    kSnapshot, ///< shared snapshot frames: dropped on resync, not counted in the budget
    kControl,  ///< replies, welcome, disconnect: never dropped
};

class OutboundQueue {
  public:
    struct Item {
        wire::Frame frame;
        FrameClass cls;
    };

    void push(wire::Frame frame, FrameClass cls);
    bool empty() const { return items_.empty(); }
    std::size_t size() const { return items_.size(); }
    /// Bytes counted against the session's budget (ops + control frames queued).
    std::size_t budgetBytes() const { return budget_bytes_; }
    /// All queued bytes including shared snapshot frames.
    std::size_t totalBytes() const { return total_bytes_; }
    const Item& at(std::size_t i) const { return items_[i]; }
    void popFront(std::size_t n);
    /// Drops queued op and snapshot frames from index `from` on (earlier ones are being written).
    std::size_t dropResyncable(std::size_t from);

  private:
    void account(const Item& item, bool add);

    std::deque<Item> items_;
    std::size_t budget_bytes_ = 0;
    std::size_t total_bytes_ = 0;
};

} // namespace terrain::server
