#pragma once

// The input of the fuzz targets that decode a checksummed format (snapshots, genesis deltas):
// the first byte picks a mode. 0: the input as it is. 1: byte patches of a valid encoding (each
// 5 input bytes: a 24-bit position and a value to xor), with the trailing XXH3-64 checksum fixed
// up when the next byte is odd, to reach the checks behind it. 2: a valid encoding truncated at
// a length from the next 4 bytes.

#include <xxhash.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace terrain::fuzz {

inline void fixChecksum(std::vector<std::uint8_t>& b) {
    if (b.size() < 8)
        return;
    const std::uint64_t sum = XXH3_64bits(b.data(), b.size() - 8);
    for (int i = 0; i < 8; ++i)
        b[b.size() - 8 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(sum >> (8 * i));
}

inline std::vector<std::uint8_t>
mutatedInput(const std::uint8_t* data, std::size_t size, const std::vector<std::uint8_t>& valid) {
    std::vector<std::uint8_t> input;
    const int mode = size > 0 ? data[0] % 3 : 0;
    if (mode == 0) {
        input.assign(data, data + size);
    } else if (mode == 1) {
        input = valid;
        for (std::size_t i = 1; i + 4 < size; i += 5) {
            const std::uint32_t at = (static_cast<std::uint32_t>(data[i]) << 16) |
                                     (static_cast<std::uint32_t>(data[i + 1]) << 8) | data[i + 2];
            input[at % input.size()] ^= data[i + 3] == 0 ? 1 : data[i + 3];
        }
        if (size > 1 && (data[1] & 1) != 0)
            fixChecksum(input);
    } else {
        std::size_t keep = 0;
        for (std::size_t i = 1; i < size && i < 5; ++i)
            keep = (keep << 8) | data[i];
        input.assign(
            valid.begin(), valid.begin() + static_cast<std::ptrdiff_t>(keep % (valid.size() + 1)));
    }
    return input;
}

} // namespace terrain::fuzz
