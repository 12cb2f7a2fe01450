#pragma once

// Reading a journal directory's files directly (tests check what is on disk, not what the
// Journal class says about it).

#include <terrain/journal/record_codec.h>

#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

namespace terrain::testing {

inline std::vector<std::uint8_t> readFileBytes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

struct JournalFileRecords {
    std::vector<journal::JournalRecord> records; ///< every segment's records, in file order
    std::size_t undecodable = 0; ///< segments that ended in a record that does not decode
};

/// The records of every segment (`*.tjl`) in name order; a segment is read up to its first
/// record that does not decode (a torn tail).
inline JournalFileRecords readJournalRecords(const std::filesystem::path& dir) {
    std::vector<std::filesystem::path> segments;
    for (const auto& entry : std::filesystem::directory_iterator(dir))
        if (entry.path().extension() == ".tjl")
            segments.push_back(entry.path());
    std::sort(segments.begin(), segments.end());
    JournalFileRecords out;
    for (const auto& path : segments) {
        const std::vector<std::uint8_t> bytes = readFileBytes(path);
        for (std::size_t at = journal::kSegmentHeaderSize;
             at + journal::kRecordSize <= bytes.size(); at += journal::kRecordSize) {
            auto record = journal::decodeRecord({bytes.data() + at, journal::kRecordSize});
            if (!record) {
                ++out.undecodable;
                break;
            }
            out.records.push_back(*record);
        }
    }
    return out;
}

} // namespace terrain::testing
