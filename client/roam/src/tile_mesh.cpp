#include <terrain/roam/tile_mesh.h>

#include <algorithm>

namespace terrain::roam {

std::size_t TileMesh::hashKey(std::uint32_t key) {
    // murmur3's 32-bit finaliser: keys are structured coordinates
    key ^= key >> 16;
    key *= 0x85ebca6bu;
    key ^= key >> 13;
    key *= 0xc2b2ae35u;
    key ^= key >> 16;
    return static_cast<std::size_t>(key);
}

void TileMesh::clear() {
    indices_.clear();
    keys_of_slots_.clear();
    free_slots_.clear();
    std::fill(table_keys_.begin(), table_keys_.end(), kNoKey);
    table_used_ = 0;
    live_ = 0;
    for (const std::uint32_t page : dirty_pages_)
        page_dirty_[page] = 0;
    dirty_pages_.clear();
    cleared_ = true;
    ++counters_.rebuilds;
}

std::uint32_t TileMesh::find(std::uint32_t key) const {
    if (table_keys_.empty())
        return kEmpty;
    const std::size_t mask = table_keys_.size() - 1;
    for (std::size_t i = hashKey(key) & mask;; i = (i + 1) & mask) {
        if (table_keys_[i] == key)
            return table_slots_[i];
        if (table_keys_[i] == kNoKey)
            return kEmpty;
    }
}

void TileMesh::growTable() {
    resizeTable(std::max<std::size_t>(64, table_keys_.size() * 2));
}

void TileMesh::resizeTable(std::size_t size) {
    std::vector<std::uint32_t> keys(size, kNoKey);
    std::vector<std::uint32_t> slots(size, 0);
    const std::size_t mask = size - 1;
    for (std::size_t j = 0; j < table_keys_.size(); ++j) {
        if (table_keys_[j] == kNoKey)
            continue;
        std::size_t i = hashKey(table_keys_[j]) & mask;
        while (keys[i] != kNoKey)
            i = (i + 1) & mask;
        keys[i] = table_keys_[j];
        slots[i] = table_slots_[j];
    }
    table_keys_.swap(keys);
    table_slots_.swap(slots);
}

void TileMesh::insertKey(std::uint32_t key, std::uint32_t slot) {
    if (std::size_t{table_used_ + 1} * 10 > table_keys_.size() * 7)
        growTable();
    const std::size_t mask = table_keys_.size() - 1;
    std::size_t i = hashKey(key) & mask;
    while (table_keys_[i] != kNoKey)
        i = (i + 1) & mask;
    table_keys_[i] = key;
    table_slots_[i] = slot;
    ++table_used_;
}

void TileMesh::eraseKey(std::uint32_t key) {
    const std::size_t mask = table_keys_.size() - 1;
    std::size_t i = hashKey(key) & mask;
    while (table_keys_[i] != key)
        i = (i + 1) & mask;
    // backward-shift: pull later entries of the probe run into the hole
    std::size_t hole = i;
    for (std::size_t j = (i + 1) & mask; table_keys_[j] != kNoKey; j = (j + 1) & mask) {
        const std::size_t home = hashKey(table_keys_[j]) & mask;
        const bool movable = (j > hole) ? (home <= hole || home > j) : (home <= hole && home > j);
        if (movable) {
            table_keys_[hole] = table_keys_[j];
            table_slots_[hole] = table_slots_[j];
            hole = j;
        }
    }
    table_keys_[hole] = kNoKey;
    --table_used_;
}

void TileMesh::write(std::uint32_t slot, const Indices& indices) {
    std::copy(
        indices.begin(), indices.end(), indices_.begin() + 3 * static_cast<std::ptrdiff_t>(slot));
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

void TileMesh::add(std::uint32_t key, const Indices& indices) {
    std::uint32_t slot = 0;
    if (!free_slots_.empty()) {
        slot = free_slots_.back();
        free_slots_.pop_back();
    } else {
        slot = slotCount();
        keys_of_slots_.push_back(kNoKey);
        indices_.resize(indices_.size() + 3);
    }
    keys_of_slots_[slot] = key;
    insertKey(key, slot);
    write(slot, indices);
    ++live_;
}

bool TileMesh::remove(std::uint32_t key) {
    const std::uint32_t slot = find(key);
    if (slot == kEmpty)
        return false;
    eraseKey(key);
    keys_of_slots_[slot] = kNoKey;
    free_slots_.push_back(slot);
    write(slot, {0, 0, 0});
    --live_;
    return true;
}

void TileMesh::fillHoles() {
    while (!free_slots_.empty()) {
        // free slots at the end just go
        while (!keys_of_slots_.empty() && keys_of_slots_.back() == kNoKey) {
            keys_of_slots_.pop_back();
            indices_.resize(indices_.size() - 3);
        }
        const std::uint32_t hole = free_slots_.back();
        free_slots_.pop_back();
        if (hole >= slotCount())
            continue; // cut off with the end
        // the last triangle moves into the hole: one slot written, its key follows it
        const std::uint32_t last = slotCount() - 1;
        const std::uint32_t key = keys_of_slots_[last];
        const Indices moved = {indices_[3 * last], indices_[3 * last + 1], indices_[3 * last + 2]};
        keys_of_slots_[hole] = key;
        write(hole, moved);
        const std::size_t mask = table_keys_.size() - 1;
        std::size_t i = hashKey(key) & mask;
        while (table_keys_[i] != key)
            i = (i + 1) & mask;
        table_slots_[i] = hole;
        keys_of_slots_.pop_back();
        indices_.resize(indices_.size() - 3);
    }
}

void TileMesh::shrink() {
    // what the peak list held, where a quarter of it is in use at most (a list that merely
    // breathes is not shrunk and regrown)
    constexpr std::size_t kKeep = 1024; // slots
    if (keys_of_slots_.capacity() > 4 * keys_of_slots_.size() + kKeep) {
        keys_of_slots_.shrink_to_fit();
        indices_.shrink_to_fit();
        std::vector<std::uint32_t>(free_slots_).swap(free_slots_);
    }
    if (table_keys_.size() > 4 * kKeep && std::size_t{table_used_} * 8 < table_keys_.size()) {
        std::size_t size = 64;
        while (std::size_t{table_used_} * 10 > size * 3) // about 30 % full after
            size *= 2;
        resizeTable(size);
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
    cleared_ = false;
}

} // namespace terrain::roam
