#include <terrain/assert.h>
#include <terrain/roam/tile_mesh.h>

#include <algorithm>

namespace terrain::roam {

namespace {

std::uint32_t hashKey(std::uint32_t key) {
    // murmur3's 32-bit finaliser: keys are structured coordinates
    key ^= key >> 16;
    key *= 0x85ebca6bu;
    key ^= key >> 13;
    key *= 0xc2b2ae35u;
    key ^= key >> 16;
    return key;
}

// Lists grow by a quarter: a tile's list is most of its memory, and doubling left it half empty
// on average.
template <class T> void growByAQuarter(std::vector<T>& v, std::size_t needed) {
    if (needed > v.capacity())
        v.reserve(std::max(needed, v.capacity() + v.capacity() / 4 + 64));
}

} // namespace

std::size_t TileMesh::home(std::uint32_t key, std::size_t size) {
    // scaled rather than masked, so that the table can have any size
    return static_cast<std::size_t>((std::uint64_t{hashKey(key)} * size) >> 32);
}

void TileMesh::clear() {
    indices_.clear();
    drawn_.clear();
    std::fill(uses_.begin(), uses_.end(), std::uint8_t{0});
    slots_.clear();
    taken_slots_.clear();
    taken_overflow_ = false;
    keys_of_slots_.clear();
    free_slots_.clear();
    std::fill(table_.begin(), table_.end(), kEmptyEntry);
    table_used_ = 0;
    live_ = 0;
    for (const std::uint32_t page : dirty_pages_)
        page_dirty_[page] = 0;
    dirty_pages_.clear();
    cleared_ = true;
    ++counters_.rebuilds;
}

std::size_t TileMesh::locate(std::uint32_t key) const {
    const std::size_t size = table_.size();
    if (size == 0)
        return size;
    for (std::size_t i = home(key, size);; i = i + 1 == size ? 0 : i + 1) {
        if (keyOf(table_[i]) == key)
            return i;
        if (table_[i] == kEmptyEntry)
            return size;
    }
}

std::uint32_t TileMesh::find(std::uint32_t key) const {
    const std::size_t i = locate(key);
    return i == table_.size() ? kEmpty : static_cast<std::uint32_t>(table_[i]);
}

void TileMesh::resizeTable(std::size_t size) {
    std::vector<std::uint64_t> table(size, kEmptyEntry);
    for (const std::uint64_t entry : table_) {
        if (entry == kEmptyEntry)
            continue;
        std::size_t i = home(keyOf(entry), size);
        while (table[i] != kEmptyEntry)
            i = i + 1 == size ? 0 : i + 1;
        table[i] = entry;
    }
    table_.swap(table);
}

void TileMesh::insertKey(std::uint32_t key, std::uint32_t slot) {
    // past three quarters full, resized to half full
    if (std::size_t{table_used_ + 1} * 4 > table_.size() * 3)
        resizeTable(std::max<std::size_t>(64, std::size_t{table_used_ + 1} * 2));
    const std::size_t size = table_.size();
    std::size_t i = home(key, size);
    while (table_[i] != kEmptyEntry)
        i = i + 1 == size ? 0 : i + 1;
    table_[i] = entryOf(key, slot);
    ++table_used_;
}

void TileMesh::eraseAt(std::size_t hole) {
    const std::size_t size = table_.size();
    // backward-shift: pull later entries of the probe run into the hole, each one that would not
    // then sit before its home (cyclic distances)
    const auto distance = [size](std::size_t from, std::size_t to) {
        return to >= from ? to - from : to + size - from;
    };
    for (std::size_t j = hole + 1 == size ? 0 : hole + 1; table_[j] != kEmptyEntry;
         j = j + 1 == size ? 0 : j + 1) {
        if (distance(home(keyOf(table_[j]), size), j) >= distance(hole, j)) {
            table_[hole] = table_[j];
            hole = j;
        }
    }
    table_[hole] = kEmptyEntry;
    --table_used_;
}

void TileMesh::appendSlot() {
    growByAQuarter(keys_of_slots_, keys_of_slots_.size() + 1);
    growByAQuarter(indices_, indices_.size() + 3);
    growByAQuarter(drawn_, drawn_.size() + 3);
    keys_of_slots_.push_back(kNoKey);
    indices_.resize(indices_.size() + 3);
    drawn_.resize(drawn_.size() + 3);
}

void TileMesh::write(std::uint32_t slot, const Indices& indices, const Indices& drawn) {
    std::copy(
        indices.begin(), indices.end(), indices_.begin() + 3 * static_cast<std::ptrdiff_t>(slot));
    std::copy(drawn.begin(), drawn.end(), drawn_.begin() + 3 * static_cast<std::ptrdiff_t>(slot));
    counters_.index_bytes_written += kIndexBytesPerTriangle;
    if (cleared_)
        return; // the whole list goes up anyway
    const std::uint32_t page = slot / kSlotsPerPage;
    if (page >= page_dirty_.size())
        page_dirty_.resize(page + 1, 0);
    if (page_dirty_[page] == 0) {
        page_dirty_[page] = 1;
        dirty_pages_.push_back(page);
    }
}

TileMesh::Indices TileMesh::use(const Indices& indices, int by) {
    Indices slots{0, 0, 0};
    for (std::size_t k = 0; k < 3; ++k) {
        const std::uint32_t v = indices[k];
        if (v >= uses_.size()) {
            const std::size_t n =
                std::max<std::size_t>(v + 1, uses_.size() + uses_.size() / 4 + 64);
            uses_.reserve(n); // a quarter of growth, as the lists
            uses_.resize(n, 0);
        }
        TERRAIN_ASSERT(by > 0 || uses_[v] > 0);
        const auto after = static_cast<std::uint8_t>(uses_[v] + by);
        if (by > 0 && uses_[v] == 0) {
            slots[k] = slots_.take(v);
            if (!taken_overflow_ && !cleared_) {
                if (taken_slots_.size() >= takenLimit()) {
                    taken_overflow_ = true; // nobody takes them: no list may grow for ever
                    taken_slots_.clear();
                } else {
                    taken_slots_.push_back(slots[k]);
                }
            }
        } else if (after == 0) {
            slots_.release(v);
        } else if (by > 0) {
            slots[k] = slots_.slotOf(v);
        }
        uses_[v] = after;
    }
    return slots;
}

void TileMesh::relaySlots() {
    slots_.clear();
    for (std::uint32_t v = 0; v < uses_.size(); ++v)
        if (uses_[v] != 0)
            slots_.take(v);
    for (std::size_t i = 0; i < indices_.size(); ++i) {
        const std::uint32_t slot = slots_.slotOf(indices_[i]);
        drawn_[i] = slot == VertexSlots::kNone ? 0u : slot;
    }
    relaid_ = true;
    taken_slots_.clear();
    taken_overflow_ = false;
}

void TileMesh::add(std::uint32_t key, const Indices& indices) {
    std::uint32_t slot = 0;
    if (!free_slots_.empty()) {
        slot = free_slots_.back();
        free_slots_.pop_back();
    } else {
        slot = slotCount();
        appendSlot();
    }
    keys_of_slots_[slot] = key;
    insertKey(key, slot);
    write(slot, indices, use(indices, 1)); // (the vertices' slots: the drawn list names them)
    ++live_;
}

bool TileMesh::remove(std::uint32_t key) {
    const std::size_t at = locate(key);
    if (at == table_.size())
        return false;
    const auto slot = static_cast<std::uint32_t>(table_[at]);
    eraseAt(at);
    use({indices_[3 * slot], indices_[3 * slot + 1], indices_[3 * slot + 2]}, -1);
    keys_of_slots_[slot] = kNoKey;
    free_slots_.push_back(slot);
    write(slot, {0, 0, 0}, {0, 0, 0});
    --live_;
    return true;
}

void TileMesh::fillHoles() {
    while (!free_slots_.empty()) {
        // free slots at the end just go
        while (!keys_of_slots_.empty() && keys_of_slots_.back() == kNoKey) {
            keys_of_slots_.pop_back();
            indices_.resize(indices_.size() - 3);
            drawn_.resize(drawn_.size() - 3);
        }
        const std::uint32_t hole = free_slots_.back();
        free_slots_.pop_back();
        if (hole >= slotCount())
            continue; // cut off with the end
        // the last triangle moves into the hole: one slot written, its key follows it
        const std::uint32_t last = slotCount() - 1;
        const std::uint32_t key = keys_of_slots_[last];
        const Indices moved = {indices_[3 * last], indices_[3 * last + 1], indices_[3 * last + 2]};
        const Indices moved_drawn = {drawn_[3 * last], drawn_[3 * last + 1], drawn_[3 * last + 2]};
        keys_of_slots_[hole] = key;
        write(hole, moved, moved_drawn);
        table_[locate(key)] = entryOf(key, hole);
        keys_of_slots_.pop_back();
        indices_.resize(indices_.size() - 3);
        drawn_.resize(drawn_.size() - 3);
    }
    // mostly free slots (the view moved away): a smaller array for the readers
    if (slots_.freeCount() > 256 && slots_.freeCount() * 2 > slots_.slotCount())
        relaySlots();
}

namespace {
constexpr std::size_t kKeepSlots = 256; // slack no list gives back
} // namespace

bool TileMesh::listHasSlack() const {
    const std::size_t slots = keys_of_slots_.size();
    return keys_of_slots_.capacity() > slots + slots / 2 + kKeepSlots;
}

bool TileMesh::tableHasSlack() const {
    return table_.size() > 4 * kKeepSlots && std::size_t{table_used_} * 4 < table_.size();
}

void TileMesh::shrink() {
    if (listHasSlack()) {
        keys_of_slots_.shrink_to_fit();
        indices_.shrink_to_fit();
        drawn_.shrink_to_fit();
        std::vector<std::uint32_t>(free_slots_).swap(free_slots_);
    }
    if (tableHasSlack())
        resizeTable(std::max<std::size_t>(64, std::size_t{table_used_} * 2)); // half full after
    if (slots_.hasSlack()) {
        // free slots or pages left: the slots given afresh, in order (a reader takes the tile
        // whole); then what they do not use goes back
        if (slots_.freeCount() > 0 || slots_.freePages() > 0)
            relaySlots();
        slots_.shrink();
        std::vector<std::uint32_t>(taken_slots_).swap(taken_slots_);
    }
}

std::uint64_t TileMesh::dirtyUploadBytes() const {
    const std::uint64_t list_bytes = std::uint64_t{slotCount()} * kIndexBytesPerTriangle;
    if (cleared_)
        return list_bytes;
    std::uint64_t bytes = 0;
    for (const std::uint32_t page : dirty_pages_) {
        const std::uint64_t begin = std::uint64_t{page} * kSlotsPerPage * kIndexBytesPerTriangle;
        if (begin < list_bytes)
            bytes +=
                std::min<std::uint64_t>(kSlotsPerPage * kIndexBytesPerTriangle, list_bytes - begin);
    }
    return bytes;
}

void TileMesh::takeChanges() {
    for (const std::uint32_t page : dirty_pages_)
        page_dirty_[page] = 0;
    dirty_pages_.clear();
    taken_slots_.clear();
    taken_overflow_ = false;
    relaid_ = false;
    cleared_ = false;
}

} // namespace terrain::roam
