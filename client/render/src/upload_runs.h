#pragma once

// Runs of changed elements (vertices, index pages) to upload, one GPU copy each. Joining two runs
// sends the unchanged elements between them for nothing but saves a copy call; a driver spends
// about as long on a call as on copying a few kilobytes, so runs are joined while what a joined
// run sends stays within twice what changed in it. Bytes stay proportional to change (at most
// 2x), calls fall where changes cluster (a crater's blocks, scattered index pages).

#include <cstdint>
#include <vector>

namespace terrain::render {

struct UploadRun {
    std::uint32_t begin = 0;
    std::uint32_t end = 0;     ///< one past the last element
    std::uint32_t changed = 0; ///< elements in [begin, end) that changed
};

/// Joins neighbouring runs (sorted by begin, disjoint) greedily from the first while the joined
/// run's length is at most twice the changed elements it holds.
inline void joinRuns(std::vector<UploadRun>& runs) {
    std::size_t kept = 0;
    for (const UploadRun& r : runs) {
        if (kept > 0) {
            UploadRun& last = runs[kept - 1];
            const std::uint64_t changed = std::uint64_t{last.changed} + r.changed;
            if (std::uint64_t{r.end - last.begin} <= 2 * changed) {
                last.end = r.end;
                last.changed = static_cast<std::uint32_t>(changed);
                continue;
            }
        }
        runs[kept++] = r;
    }
    runs.resize(kept);
}

} // namespace terrain::render
