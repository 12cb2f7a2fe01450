#pragma once

// The C ABI's one rule about C++ exceptions: none crosses it. A call's body runs inside
// guardedCall, which turns whatever it throws into TERRAIN_INTERNAL and hands the message to the
// handle's own last-error text.

#include <terrain_client.h>

#include <exception>
#include <new>
#include <string>

namespace terrain::game::detail {

/// Hands "INTERNAL: <what>" to `note`; a message that cannot be made (out of memory) is dropped:
/// the status still says INTERNAL.
template <typename Note> void noteInternal(Note& note, const char* what) noexcept {
    try {
        note(std::string("INTERNAL: ") + what);
    } catch (...) {
    }
}

/// Runs `body` (returning a terrain_status); an exception becomes TERRAIN_INTERNAL, its message
/// handed to `note(std::string)`.
template <typename Note, typename Body>
terrain_status guardedCall(Note&& note, Body&& body) noexcept {
    try {
        return body();
    } catch (const std::bad_alloc&) {
        noteInternal(note, "out of memory");
    } catch (const std::exception& e) {
        noteInternal(note, e.what());
    } catch (...) {
        noteInternal(note, "an unknown exception");
    }
    return TERRAIN_INTERNAL;
}

} // namespace terrain::game::detail
