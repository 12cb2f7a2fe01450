#include <terrain/server/outbound_queue.h>

#include <utility>

namespace terrain::server {

void OutboundQueue::account(const Item& item, bool add) {
    const std::size_t n = item.frame->size();
    const std::size_t counted = item.cls == FrameClass::kSnapshot ? 0 : n;
    if (add) {
        total_bytes_ += n;
        budget_bytes_ += counted;
    } else {
        total_bytes_ -= n;
        budget_bytes_ -= counted;
    }
}

void OutboundQueue::push(wire::Frame frame, FrameClass cls) {
    items_.push_back(Item{std::move(frame), cls});
    account(items_.back(), true);
}

void OutboundQueue::popFront(std::size_t n) {
    for (std::size_t i = 0; i < n && !items_.empty(); ++i) {
        account(items_.front(), false);
        items_.pop_front();
    }
}

std::size_t OutboundQueue::dropResyncable(std::size_t from) {
    std::deque<Item> kept;
    std::size_t dropped = 0;
    for (std::size_t i = 0; i < items_.size(); ++i) {
        if (i >= from && items_[i].cls != FrameClass::kControl) {
            account(items_[i], false);
            ++dropped;
        } else {
            kept.push_back(std::move(items_[i]));
        }
    }
    items_ = std::move(kept);
    return dropped;
}

} // namespace terrain::server
