// VertexSlots: the map from a tessellator's vertices to the slots of a reader's array.

#include <terrain/roam/vertex_slots.h>

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>

namespace {

using terrain::roam::VertexSlots;

TEST(VertexSlots, EachHeldVertexHasItsOwnSlotAndAFreedSlotServesTheNext) {
    // random takes and releases against a model, over a growing and a shrinking array
    VertexSlots slots;
    std::map<std::uint32_t, std::uint32_t> model; // vertex -> slot
    std::mt19937 rng(3);
    std::uint32_t count = 5000;
    const auto check = [&] {
        std::set<std::uint32_t> used;
        for (const auto& [v, s] : model) {
            ASSERT_EQ(slots.slotOf(v), s) << v;
            ASSERT_EQ(slots.vertexOf(s), v) << s;
            ASSERT_TRUE(used.insert(s).second) << "slot " << s << " held twice";
        }
        ASSERT_EQ(slots.slotCount() - slots.freeCount(), model.size());
        for (std::uint32_t s = 0; s < slots.slotCount(); ++s) {
            if (used.count(s) == 0) {
                ASSERT_EQ(slots.vertexOf(s), VertexSlots::kNone) << s;
            }
        }
        for (std::uint32_t v = 0; v < count * 2; v += 13) {
            if (model.count(v) == 0) {
                ASSERT_EQ(slots.slotOf(v), VertexSlots::kNone) << v;
            }
        }
    };
    for (int round = 0; round < 6; ++round) {
        for (int i = 0; i < 4000; ++i) {
            // clustered, as a tile's drawn vertices are: most in a few places of the array
            const std::uint32_t v = (rng() % 4 == 0 ? rng() % count : (rng() % 600) * 3) % count;
            if (model.count(v) != 0) {
                slots.release(v);
                model.erase(v);
            } else {
                const std::uint32_t before = slots.slotCount();
                const std::uint32_t free = slots.freeCount();
                model[v] = slots.take(v);
                // a free slot first; a new one only when none is free
                ASSERT_EQ(slots.slotCount(), free > 0 ? before : before + 1);
            }
        }
        check();
        // the array shrinks: its vertices past the end go out of use
        count = round % 2 == 0 ? count * 2 : count / 3;
        for (auto it = model.begin(); it != model.end();) {
            if (it->first >= count) {
                slots.release(it->first);
                it = model.erase(it);
            } else {
                ++it;
            }
        }
        check();
    }
    // a vertex released twice, or one with no slot, changes nothing
    const std::size_t held = model.size();
    slots.release(count + 7);
    if (!model.empty()) {
        slots.release(model.begin()->first);
        slots.release(model.begin()->first);
        model.erase(model.begin());
        EXPECT_EQ(model.size() + 1, held);
    }
    check();
}

TEST(VertexSlots, ThePagesFollowTheHeldVerticesNotTheArray) {
    // a million places, a thousand held in one stretch: the map costs pages for the stretch
    VertexSlots slots;
    for (std::uint32_t v = 500'000; v < 501'000; ++v)
        slots.take(v);
    const std::size_t one_stretch = slots.memoryBytes();
    EXPECT_LT(one_stretch, 1'000'000 / VertexSlots::kPage * 4 + 40'000);
    // they all go, and another stretch elsewhere reuses the pages
    for (std::uint32_t v = 500'000; v < 501'000; ++v)
        slots.release(v);
    const std::size_t released = slots.memoryBytes(); // (the free lists hold them now)
    for (std::uint32_t v = 10'000; v < 11'000; ++v)
        EXPECT_LT(slots.take(v), 1000u) << "a freed slot";
    EXPECT_EQ(slots.memoryBytes(), released) << "the freed pages and slots served again";
    slots.clear();
    EXPECT_EQ(slots.slotCount(), 0u);
    EXPECT_EQ(slots.slotOf(10'500), VertexSlots::kNone);
}

} // namespace
