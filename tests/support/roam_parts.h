#pragma once

// The tessellator's parts without its facade, on a cratered world with every detail block
// resident: what the parts' own tests (bounds update, tile emitter) run on.

#include "support/terrain_builders.h"

#include <terrain/roam/block_pool.h>
#include <terrain/roam/bounds_update.h>
#include <terrain/roam/detail_blocks.h>
#include <terrain/roam/diamond_space.h>
#include <terrain/roam/lattice_ids.h>
#include <terrain/roam/tile_emitter.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <set>
#include <utility>
#include <vector>

namespace terrain::testing {

using roam::BlockPool;
using roam::BoundsUpdate;
using roam::DetailBlocks;
using roam::DiamondBounds;
using roam::DiamondId;
using roam::DiamondSpace;
using roam::kGrains;
using roam::kLatticePerCell;

inline Terrain crateredWorld() {
    Terrain t = makeHills(7);
    CraterSeries s;
    s.seed = 7;
    s.count = 60;
    applyAll(t, randomCraters(t.spec(), s));
    return t;
}

/// The tessellator's parts, as its facade wires them, over `terrain`: the records, a pool holding
/// a block per record in every grain, the diamond space sized to follow, the ids, the tiles
/// (every grain in its tile's vertex array), all bounded by a whole-map pass. No diamond split.
struct RoamParts {
    explicit RoamParts(const Terrain& t) : terrain(t) {
        const WorldSpec& spec = terrain.spec();
        blocks.reset(terrain);
        space.reset(
            static_cast<std::uint32_t>(spec.paddedWidth() * spec.paddedHeight()),
            roam::BoundsCodec(spec.metresPerUnit()));
        ids.reset(roam::LatticeGeometry::of(spec));
        emitter.reset(spec);
        emitter.read(terrain);
        for (std::int32_t r = 0; r < blocks.recordCapacity(); ++r) {
            if (!blocks.recordInUse(r))
                continue;
            const std::int32_t b = blocks.materialise(r);
            pool.resizeBlocks(static_cast<std::size_t>(blocks.capacity()));
            pool.adoptBlock(b, 1);
            for (int g = 1; g < kGrains; ++g)
                pool.takeChunk(b, g, 1);
            for (int g = 0; g < kGrains; ++g) {
                const std::int32_t chunk = pool.chunkOf(b, g);
                pool.segment(g, chunk) = emitter.attachGrain(b, g, chunk);
            }
        }
        space.resizeCentres(static_cast<std::size_t>(blocks.recordCapacity()));
        for (int g = 0; g < kGrains; ++g)
            space.resizeChunks(g, pool.chunkCount(g));
        bounds.reset(
            terrain, {spec, spec.metresPerUnit() / static_cast<double>(roam::kFineUnitsPerQuantum),
                      (spec.paddedWidth() - 1) * kLatticePerCell,
                      (spec.paddedHeight() - 1) * kLatticePerCell});
        bounds.recomputeAll();
    }

    /// Every diamond's bounds: the grid's, the centres', each grain's chunks' (in id order).
    std::vector<DiamondBounds> everyBound() const {
        std::vector<DiamondBounds> all;
        for (DiamondId id = 0; id < space.gridCount(); ++id)
            all.push_back(bounds.bounds(id));
        for (std::int32_t r = 0; r < blocks.recordCapacity(); ++r)
            all.push_back(
                blocks.recordInUse(r) ? bounds.bounds(space.centreId(r)) : DiamondBounds{});
        for (const DiamondId id : pooledIds())
            all.push_back(bounds.bounds(id));
        return all;
    }
    std::vector<DiamondId> everyId() const {
        std::vector<DiamondId> all;
        for (DiamondId id = 0; id < space.gridCount(); ++id)
            all.push_back(id);
        for (std::int32_t r = 0; r < blocks.recordCapacity(); ++r)
            all.push_back(blocks.recordInUse(r) ? space.centreId(r) : roam::kNoDiamond);
        for (const DiamondId id : pooledIds())
            all.push_back(id);
        return all;
    }
    std::vector<DiamondId> pooledIds() const {
        std::vector<DiamondId> pooled;
        for (int g = 0; g < kGrains; ++g)
            for (std::size_t c = 0; c < pool.chunkCount(g); ++c)
                for (std::int32_t slot = 0;
                     slot < roam::kGrainDiamonds[static_cast<std::size_t>(g)]; ++slot)
                    pooled.push_back(DiamondSpace::pooledId(
                        g, static_cast<std::int32_t>(c), static_cast<std::uint32_t>(slot)));
        return pooled;
    }
    /// Every resident grain's base and heights.
    std::vector<std::int64_t> everyHeight() const {
        std::vector<std::int64_t> all;
        for (int g = 0; g < kGrains; ++g)
            for (std::size_t c = 0; c < pool.chunkCount(g); ++c) {
                const auto chunk = static_cast<std::int32_t>(c);
                all.push_back(pool.base(g, chunk));
                for (const std::uint32_t h : pool.heights(g, chunk))
                    all.push_back(h);
            }
        return all;
    }
    /// Applies `request` to the terrain and its detail records, telling the bounds update what
    /// the tessellator tells it before the records change; the cells it changed. The op must
    /// leave the records where they were (the tessellator evicts the blocks of records that go
    /// first: not this test's subject).
    CellRect change(const OpRequest& request) {
        auto op = quantizeOp(request, terrain.spec());
        EXPECT_TRUE(op.ok());
        auto effect = terrain.apply(*op);
        EXPECT_TRUE(effect.ok());
        const CellRect r = effect->cells;
        bounds.surfaceChanged();
        std::vector<std::int32_t> removing;
        blocks.plan(terrain, r, removing);
        EXPECT_TRUE(removing.empty()) << "the op removes detail records: pick another";
        bounds.noteCentres(r);
        std::vector<std::int32_t> removed;
        std::vector<std::int32_t> added;
        blocks.update(terrain, r, removed, added);
        EXPECT_TRUE(added.empty()) << "the op adds detail records: pick another";
        return r;
    }
    /// change(), then the op's passes: the stale blocks queued, the grid and centres redone.
    void apply(const OpRequest& request) {
        const CellRect r = change(request);
        bounds.markStale(r);
        bounds.recomputeAround(r);
    }

    Terrain terrain;
    DetailBlocks blocks;
    BlockPool pool;
    DiamondSpace space;
    roam::LatticeIds ids{blocks, pool, space};
    roam::TileEmitter emitter{blocks, pool, ids};
    BoundsUpdate bounds{blocks, pool, space, emitter.vertices()};
};

/// The detail cells of `t` (the cells with a record).
inline std::set<std::pair<std::int32_t, std::int32_t>> detailCells(const Terrain& t) {
    DetailBlocks b;
    b.reset(t);
    std::set<std::pair<std::int32_t, std::int32_t>> cells;
    for (std::int32_t r = 0; r < b.recordCapacity(); ++r)
        if (b.recordInUse(r))
            cells.insert({b.recordCell(r).x, b.recordCell(r).y});
    return cells;
}

/// A small crater on a detail cell near the map's middle that leaves the detail cells as they
/// were (the first such, trying the cells nearest the middle first).
inline OpRequest craterKeepingTheRecords(const RoamParts& w) {
    const WorldSpec& spec = w.terrain.spec();
    const std::set<std::pair<std::int32_t, std::int32_t>> before = detailCells(w.terrain);
    std::vector<std::pair<std::int64_t, std::pair<std::int32_t, std::int32_t>>> near;
    for (const auto& c : before) {
        const std::int64_t dx = c.first - spec.cellsX() / 2;
        const std::int64_t dy = c.second - spec.cellsY() / 2;
        near.push_back({dx * dx + dy * dy, c});
    }
    std::sort(near.begin(), near.end());
    for (std::size_t i = 0; i < near.size() && i < 200; ++i) {
        OpRequest req;
        req.kind = OpKind::kCrater;
        req.x = (near[i].second.first + 0.5) * spec.spacingMetres();
        req.y = (near[i].second.second + 0.5) * spec.spacingMetres();
        req.radius = 1.5;
        req.height = 0.4;
        req.strength = 0.5;
        Terrain trial = w.terrain;
        applyAll(trial, {req});
        if (detailCells(trial) == before)
            return req;
    }
    ADD_FAILURE() << "no crater near the middle keeps the detail cells";
    return {};
}

} // namespace terrain::testing
