#pragma once

// The replica -> tessellator edge of a client frame: what the replica changed (ops' cell
// rectangles, repaired tiles, a whole snapshot) becomes the tessellator's terrainChanged().

#include <terrain/client/replica.h>
#include <terrain/roam/tessellator.h>

#include <vector>

namespace terrain::client {

/// What the replica changed, as the tessellator and the renderer take it: cell rectangles (ops'
/// own, then repaired tiles as theirs), or `all` after a snapshot (no rectangles then).
struct SurfaceChanges {
    std::vector<CellRect> cells;
    bool all = false;
    bool any() const { return all || !cells.empty(); }
};

SurfaceChanges surfaceChanges(const DirtySet& dirty, const WorldSpec& spec);

/// Hands `changes` to `tess`, built on the replica's terrain (a snapshot resets it: it adopts a
/// new world's size). Returns changes.any(). A renderer learns what to redraw from the
/// tessellator (its vertex ranges and index pages), not from the replica.
bool feedChanges(const SurfaceChanges& changes, roam::Tessellator& tess);

} // namespace terrain::client
