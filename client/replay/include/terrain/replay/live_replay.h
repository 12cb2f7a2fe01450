#pragma once

// A recorded match replayed through a live server (live_run.h): the journal's base state
// becomes the server's, the feeder sends the journal's ops in order, and every client's world
// hash is checked against the hash the journal recorded, at every seq. The live server must
// accept every op at the journal's seq. The first divergence keeps a copy of the diverged state
// for a desync report (desync_report.h).

#include <terrain/journal/journal.h>
#include <terrain/replay/live_run.h>
#include <terrain/result.h>

#include <cstdint>

namespace terrain::replay {

/// Every client checked every seq and agreed with the journal, and the live server accepted
/// every op at its recorded seq.
bool replayAgreed(const journal::JournalHistory& history, const LiveRunResult& result);

/// Replays `history` through a live server to `options.clients` clients.
/// Errors: runLive()'s.
Result<LiveRunResult>
runLiveReplay(const journal::JournalHistory& history, const LiveRunOptions& options);

/// The journal's state after record `seq` (history.base_seq <= seq <= the last record's),
/// replayed offline: the expected side of a desync report.
/// Errors: kOutOfRange for a seq outside the history; apply()'s.
Result<Terrain> stateAt(const journal::JournalHistory& history, std::uint64_t seq);

} // namespace terrain::replay
