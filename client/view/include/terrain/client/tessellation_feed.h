#pragma once

// The replica -> tessellator edge of a client frame: what the replica changed (ops' cell
// rectangles, repaired tiles, a whole snapshot) becomes the tessellator's terrainChanged().

#include <terrain/client/replica.h>
#include <terrain/roam/tessellator.h>

#include <vector>

namespace terrain::client {

/// The cells `dirty` covers: ops' rectangles, then repaired tiles as theirs (empty for a
/// snapshot: `dirty.all` says everything). The renderer's surfaceChanged() takes the same.
std::vector<CellRect> changedCells(const DirtySet& dirty, const WorldSpec& spec);

/// Hands `dirty` (from Replica::takeDirty) to `tess`, built on the replica's terrain. Repaired
/// tiles become their cell rectangles; a snapshot resets the tessellator (which adopts a new
/// world's size). Returns false when nothing changed.
bool feedChanges(const DirtySet& dirty, const WorldSpec& spec, roam::Tessellator& tess);

} // namespace terrain::client
