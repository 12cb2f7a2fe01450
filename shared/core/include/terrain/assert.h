#pragma once

// TERRAIN_ASSERT: for bugs only (broken preconditions and invariants), never for data that came
// from outside the process. Active in debug builds and wherever TERRAIN_FORCE_ASSERTS is defined.

#include <cstdio>
#include <cstdlib>

#if !defined(NDEBUG) || defined(TERRAIN_FORCE_ASSERTS)
#define TERRAIN_ASSERT(cond)                                                                       \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            std::fprintf(stderr, "%s:%d: assertion failed: %s\n", __FILE__, __LINE__, #cond);      \
            std::abort();                                                                          \
        }                                                                                          \
    } while (false)
#else
#define TERRAIN_ASSERT(cond)                                                                       \
    do {                                                                                           \
        (void)sizeof(cond);                                                                        \
    } while (false)
#endif
