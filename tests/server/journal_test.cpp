#include "support/terrain_builders.h"

#include <terrain/journal/journal.h>
#include <terrain/journal/record_codec.h>
#include <terrain/snapshot.h>

#include <gtest/gtest.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace terrain::journal {
namespace {

namespace fs = std::filesystem;

std::vector<std::uint8_t> readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const fs::path& p, const std::vector<std::uint8_t>& bytes) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(
        reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

/// Journal files whose name starts with `prefix`, in name (= seq) order.
std::vector<fs::path> filesStartingWith(const fs::path& dir, const std::string& prefix) {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (name.starts_with(prefix) && !name.ends_with(".tmp"))
            out.push_back(e.path());
    }
    std::sort(out.begin(), out.end());
    return out;
}

std::size_t recordOffset(std::size_t index) {
    return kSegmentHeaderSize + index * kRecordSize;
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

/// A small world, 200 canonical craters, and the live terrain's hash after each of them.
class JournalTest : public ::testing::Test {
  protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = fs::temp_directory_path() /
               ("terrain-journal-" + std::string(info->name()) + "-" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        CraterSeries series;
        series.seed = 5;
        series.count = 200;
        for (const OpRequest& r : randomCraters(genesis_.spec(), series)) {
            auto op = quantizeOp(r, genesis_.spec());
            ASSERT_TRUE(op.ok()) << op.error().message;
            ops_.push_back(*op);
        }
        hashes_.push_back(genesis_.worldHash());
    }
    void TearDown() override { fs::remove_all(dir_); }

    /// Opens the directory; fails the test when it cannot.
    Journal openJournal(JournalOptions options = {}) {
        auto j = Journal::open(dir_, options);
        EXPECT_TRUE(j.ok()) << j.error().message;
        return std::move(*j);
    }

    /// Applies ops seq (live_seq_, up_to] to the live terrain and journals them, committing every
    /// `group` records (the last group may be shorter).
    void journalOps(Journal& j, std::uint64_t up_to, std::size_t group = 7) {
        while (live_seq_ < up_to) {
            const DeformOp& op = ops_[live_seq_];
            ASSERT_TRUE(live_.apply(op).ok());
            ++live_seq_;
            if (hashes_.size() <= live_seq_)
                hashes_.push_back(live_.worldHash());
            j.append({live_seq_, op, live_.worldHash()});
            if (j.pending() == group || live_seq_ == up_to) {
                ASSERT_TRUE(j.commit().ok());
            }
        }
        EXPECT_EQ(j.lastSeq(), up_to);
    }

    /// A journal at `records` records committed, one segment, no later snapshot.
    void makeJournal(std::uint64_t records) {
        Journal j = openJournal();
        ASSERT_TRUE(j.initialize(genesis_).ok());
        journalOps(j, records);
    }

    Result<RecoveredState> recoverFresh(JournalOptions options = {}) {
        Journal j = openJournal(options);
        return j.recover();
    }

    fs::path dir_;
    Terrain genesis_ = testing::makeHills(3, 129, 129);
    Terrain live_ = genesis_;
    std::uint64_t live_seq_ = 0;
    std::vector<DeformOp> ops_;
    std::vector<std::uint64_t> hashes_; // world hash after seq i
};

TEST(Durability, parsesTheTwoPoliciesAndNamesTheRuleOtherwise) {
    ASSERT_TRUE(parseDurability("fsync").ok());
    EXPECT_EQ(*parseDurability("fsync"), Durability::kFsync);
    EXPECT_EQ(*parseDurability("write"), Durability::kWrite);
    for (const char* bad : {"", "FSYNC", "sync", "fsync ", "none"}) {
        auto d = parseDurability(bad);
        ASSERT_FALSE(d.ok()) << bad;
        EXPECT_EQ(d.error().code, ErrorCode::kBadFormat);
        EXPECT_TRUE(contains(d.error().message, "fsync, write")) << d.error().message;
    }
    EXPECT_EQ(*parseDurability(toString(Durability::kWrite)), Durability::kWrite);
}

TEST(RecordCodec, roundTripsAndRejectsEachBadInput) {
    const JournalRecord r{
        0x0102030405060708ull, DeformOp{OpKind::kFlatten, -5, 1ll << 40, 77, -300, 1234},
        0xfedcba9876543210ull};
    std::vector<std::uint8_t> bytes;
    appendRecord(r, bytes);
    ASSERT_EQ(bytes.size(), kRecordSize);
    auto back = decodeRecord(bytes);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(*back, r);
    EXPECT_EQ(
        decodeRecord(std::span(bytes).first(kRecordSize - 1)).error().code, ErrorCode::kTruncated);
    for (std::size_t at = 0; at < kRecordSize; ++at) {
        auto bad = bytes;
        bad[at] ^= 0x10;
        EXPECT_FALSE(decodeRecord(bad).ok()) << at;
    }
    std::vector<std::uint8_t> header;
    appendSegmentHeader(42, header);
    ASSERT_EQ(header.size(), kSegmentHeaderSize);
    EXPECT_EQ(*decodeSegmentHeader(header), 42u);
    header[5] ^= 1;
    EXPECT_FALSE(decodeSegmentHeader(header).ok());
    // a version 1 segment (v1 craters), checksum intact, is refused by name
    std::vector<std::uint8_t> v1;
    appendSegmentHeader(42, v1);
    v1[4] = 1;
    const std::uint64_t sum = XXH3_64bits(v1.data(), 16);
    for (int b = 0; b < 8; ++b)
        v1[static_cast<std::size_t>(16 + b)] = static_cast<std::uint8_t>(sum >> (8 * b));
    const auto refused = decodeSegmentHeader(v1);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(
        refused.error().message.find("journal segment version 1 is not supported"),
        std::string::npos);
    EXPECT_NE(refused.error().message.find("reads version 2"), std::string::npos)
        << refused.error().message;
}

TEST_F(JournalTest, roundTripsTwoHundredCratersToTheSameSeqAndHash) {
    {
        Journal j = openJournal();
        EXPECT_TRUE(j.empty());
        ASSERT_TRUE(j.initialize(genesis_).ok());
        EXPECT_FALSE(j.empty());
        journalOps(j, 200);
        EXPECT_EQ(j.stats().records_written, 200u);
        EXPECT_EQ(j.stats().bytes_written, 200u * kRecordSize);
        EXPECT_EQ(j.stats().commits, 29u); // 28 groups of 7, then 4
        EXPECT_EQ(j.stats().fsyncs, 29u);
    }
    EXPECT_EQ(fs::file_size(filesStartingWith(dir_, "journal-").at(0)), recordOffset(200));
    auto r = recoverFresh();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->seq, 200u);
    EXPECT_EQ(r->snapshot_seq, 0u);
    EXPECT_EQ(r->replayed_records, 200u);
    EXPECT_EQ(r->torn_bytes_dropped, 0u);
    EXPECT_EQ(r->terrain.worldHash(), live_.worldHash());
    EXPECT_EQ(r->terrain.worldHash(), testing::freshHash(live_));
}

TEST_F(JournalTest, writePolicyCommitsWithoutFsyncAndRecovers) {
    {
        Journal j = openJournal({Durability::kWrite, 2});
        ASSERT_TRUE(j.initialize(genesis_, 1000).ok());
        live_seq_ = 0;
        // seqs continue from the genesis seq
        for (std::uint64_t i = 0; i < 20; ++i) {
            ASSERT_TRUE(live_.apply(ops_[i]).ok());
            j.append({1001 + i, ops_[i], live_.worldHash()});
        }
        EXPECT_EQ(j.pending(), 20u);
        EXPECT_EQ(j.lastSeq(), 1000u); // nothing is durable before commit()
        ASSERT_TRUE(j.commit().ok());
        EXPECT_EQ(j.lastSeq(), 1020u);
        EXPECT_EQ(j.stats().commits, 1u);
        EXPECT_EQ(j.stats().fsyncs, 0u);
    }
    auto r = recoverFresh();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->seq, 1020u);
    EXPECT_EQ(r->terrain.worldHash(), live_.worldHash());
}

TEST_F(JournalTest, commitWithNothingPendingIsANoOp) {
    Journal j = openJournal();
    ASSERT_TRUE(j.initialize(genesis_).ok());
    const auto segment = filesStartingWith(dir_, "journal-").at(0);
    ASSERT_TRUE(j.commit().ok());
    ASSERT_TRUE(j.commit().ok());
    EXPECT_EQ(j.stats().commits, 0u);
    EXPECT_EQ(j.stats().fsyncs, 0u);
    EXPECT_EQ(fs::file_size(segment), kSegmentHeaderSize);
    journalOps(j, 3);
    ASSERT_TRUE(j.commit().ok());
    EXPECT_EQ(j.stats().commits, 1u);
    EXPECT_EQ(fs::file_size(segment), recordOffset(3));
}

TEST_F(JournalTest, refusesMisuseOfTheDirectory) {
    EXPECT_EQ(recoverFresh().error().code, ErrorCode::kIo); // nothing to recover
    Journal j = openJournal();
    // one writer per directory
    auto second = Journal::open(dir_, {});
    ASSERT_FALSE(second.ok());
    EXPECT_TRUE(contains(second.error().message, "locked")) << second.error().message;
    ASSERT_TRUE(j.initialize(genesis_).ok());
    journalOps(j, 5);
    ASSERT_TRUE(live_.apply(ops_[5]).ok());
    j.append({6, ops_[5], live_.worldHash()});
    EXPECT_EQ(j.writeSnapshot(live_, 6).error().code, ErrorCode::kOutOfRange); // 6 is pending
    EXPECT_EQ(j.writeSnapshot(live_, 7).error().code, ErrorCode::kOutOfRange);
    ASSERT_TRUE(j.commit().ok());
    EXPECT_TRUE(j.writeSnapshot(live_, 6).ok());
    EXPECT_EQ(j.failure(), nullptr);
}

TEST_F(JournalTest, initializeRefusesADirectoryThatHoldsAJournal) {
    makeJournal(3);
    Journal j = openJournal();
    EXPECT_FALSE(j.empty());
    auto s = j.initialize(genesis_);
    ASSERT_FALSE(s.ok());
    EXPECT_TRUE(contains(s.error().message, "already holds a journal")) << s.error().message;
    auto r = j.recover();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->seq, 3u);
}

TEST_F(JournalTest, snapshotsRotateSegmentsPruneAndRecoveryReplaysOnlyTheTail) {
    {
        Journal j = openJournal({Durability::kFsync, 2});
        ASSERT_TRUE(j.initialize(genesis_).ok());
        for (std::uint64_t at : {60u, 120u, 180u}) {
            journalOps(j, at);
            ASSERT_TRUE(j.writeSnapshot(live_, at).ok());
        }
        ASSERT_TRUE(j.writeSnapshot(live_, 180).ok()); // again at the same seq: no new segment
        journalOps(j, 200);
        EXPECT_EQ(j.stats().snapshots_written, 5u);
    }
    auto names = [&](const std::string& prefix) {
        std::vector<std::string> out;
        for (const auto& p : filesStartingWith(dir_, prefix))
            out.push_back(p.filename().string());
        return out;
    };
    EXPECT_EQ(
        names("snapshot-"),
        (std::vector<std::string>{
            "snapshot-00000000000000000120.trsn", "snapshot-00000000000000000180.trsn"}));
    EXPECT_EQ(
        names("journal-"),
        (std::vector<std::string>{
            "journal-00000000000000000121.tjl", "journal-00000000000000000181.tjl"}));

    auto r = recoverFresh();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->snapshot_seq, 180u);
    EXPECT_EQ(r->replayed_records, 20u);
    EXPECT_EQ(r->seq, 200u);
    EXPECT_EQ(r->terrain.worldHash(), live_.worldHash());

    // a damaged newest snapshot: recovery falls back to the older one and replays more
    const auto newest = filesStartingWith(dir_, "snapshot-").back();
    auto bytes = readBytes(newest);
    bytes[bytes.size() / 2] ^= 0x40;
    writeBytes(newest, bytes);
    auto fallback = recoverFresh();
    ASSERT_TRUE(fallback.ok()) << fallback.error().message;
    EXPECT_EQ(fallback->snapshot_seq, 120u);
    EXPECT_EQ(fallback->replayed_records, 80u);
    EXPECT_EQ(fallback->terrain.worldHash(), live_.worldHash());
    ASSERT_FALSE(fallback->notes.empty());
    EXPECT_TRUE(contains(fallback->notes[0], "snapshot-00000000000000000180.trsn skipped"));
}

// streamed to the disk a piece at a time (the flushes start past 2 MB): the same bytes as
// encodeSnapshot(), and no temp file left
TEST_F(JournalTest, aSnapshotFileIsTheEncodedSnapshotAndLeavesNoTempFile) {
    fs::create_directories(dir_);
    Terrain big = testing::makeHills(9, 700, 600);
    auto op = quantizeOp({OpKind::kCrater, 300, 300, 6.0, 2.0, 0.3}, big.spec());
    ASSERT_TRUE(op.ok());
    ASSERT_TRUE(big.apply(*op).ok());
    const auto expected = encodeSnapshot(big, 42);
    ASSERT_GT(expected.size(), std::size_t{3} << 20);
    ASSERT_TRUE(writeSnapshotFile(dir_, big, 42).ok());
    ASSERT_TRUE(writeSnapshotFile(dir_, big, 42).ok()); // again over it: replaced whole
    const auto files = filesStartingWith(dir_, "");
    ASSERT_EQ(files.size(), 1u);
    EXPECT_EQ(readBytes(files[0]), expected);
    for (const auto& e : fs::directory_iterator(dir_))
        EXPECT_FALSE(e.path().string().ends_with(".tmp")) << e.path();
    // an unwritable place: the error names it, and nothing is left behind
    auto refused = writeSnapshotFile(dir_ / "missing", big, 42);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::kIo);
    EXPECT_TRUE(contains(refused.error().message, "missing")) << refused.error().message;
}

// the server's setting: a snapshot keeps the current segment until it holds segment_records
// records, so that it costs the io thread no file creation; recovery replays from the middle
TEST_F(JournalTest, segmentsRotateBySizeAndRecoveryStartsInTheMiddleOfOne) {
    JournalOptions options{Durability::kFsync, 2};
    options.segment_records = 100;
    {
        Journal j = openJournal(options);
        ASSERT_TRUE(j.initialize(genesis_).ok());
        journalOps(j, 40);
        ASSERT_TRUE(j.beginSnapshot(40).ok());
        ASSERT_TRUE(j.snapshotWritten(writeSnapshotFile(dir_, live_, 40)).ok());
        journalOps(j, 80);
        ASSERT_TRUE(j.writeSnapshot(live_, 80).ok()); // 80 records: the segment goes on
        journalOps(j, 130);
        ASSERT_TRUE(j.beginSnapshot(130).ok()); // 130 records: journal-131 starts
        ASSERT_TRUE(j.snapshotWritten(writeSnapshotFile(dir_, live_, 130)).ok());
        journalOps(j, 150);
        EXPECT_EQ(j.snapshotSeq(), 130u);
    }
    std::vector<std::string> segments;
    for (const auto& p : filesStartingWith(dir_, "journal-"))
        segments.push_back(p.filename().string());
    // snapshots 80 and 130 kept: records 81 ... 130 are in the first segment, which stays
    EXPECT_EQ(
        segments, (std::vector<std::string>{
                      "journal-00000000000000000001.tjl", "journal-00000000000000000131.tjl"}));
    EXPECT_EQ(filesStartingWith(dir_, "snapshot-").size(), 2u);
    auto r = recoverFresh(options);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->snapshot_seq, 130u);
    EXPECT_EQ(r->replayed_records, 20u);
    EXPECT_EQ(r->terrain.worldHash(), live_.worldHash());
    auto v = verifyJournal(dir_);
    ASSERT_TRUE(v.ok()) << v.error().message;
    EXPECT_EQ(v->last_seq, 150u);

    // a crash after a snapshot in the middle of the newest segment: recovery replays from the
    // record after it, in the same file, and the journal goes on appending there
    fs::remove(filesStartingWith(dir_, "snapshot-").back());
    {
        Journal j = openJournal(options);
        auto again = j.recover();
        ASSERT_TRUE(again.ok()) << again.error().message;
        EXPECT_EQ(again->snapshot_seq, 80u);
        EXPECT_EQ(again->replayed_records, 70u);
        EXPECT_EQ(again->terrain.worldHash(), live_.worldHash());
        journalOps(j, 160);
        ASSERT_TRUE(j.writeSnapshot(live_, 160).ok()); // 30 records in journal-131: goes on
    }
    EXPECT_EQ(filesStartingWith(dir_, "journal-").size(), 2u);
    auto last = recoverFresh(options);
    ASSERT_TRUE(last.ok()) << last.error().message;
    EXPECT_EQ(last->snapshot_seq, 160u);
    EXPECT_EQ(last->replayed_records, 0u);
    EXPECT_EQ(last->terrain.worldHash(), live_.worldHash());
}

TEST_F(JournalTest, recoveredHistoryReachesBackPastTheSnapshotAsFarAsTheSegmentsGo) {
    // for the server's retained log: the last records before the recovered state, with the
    // state they start from, read from every segment still on disk
    {
        Journal j = openJournal({Durability::kFsync, 2});
        ASSERT_TRUE(j.initialize(genesis_).ok());
        for (std::uint64_t at : {60u, 120u, 180u}) {
            journalOps(j, at);
            ASSERT_TRUE(j.writeSnapshot(live_, at).ok());
        }
        journalOps(j, 200); // on disk: snapshots 120 and 180, records 121 ... 200
    }
    const auto expectHistory = [&](const RecoveredHistory& h, std::uint64_t base) {
        EXPECT_EQ(h.base_seq, base);
        EXPECT_EQ(h.base_hash, hashes_[base]);
        ASSERT_EQ(h.records.size(), 200 - base);
        for (std::size_t i = 0; i < h.records.size(); ++i) {
            const JournalRecord& r = h.records[i];
            ASSERT_EQ(r.seq, base + 1 + i);
            EXPECT_EQ(r.op, ops_[r.seq - 1]);
            EXPECT_EQ(r.world_hash, hashes_[r.seq]);
        }
    };
    // a crash: 20 records replayed after snapshot 180, 30 more read back from before it
    {
        Journal j = openJournal();
        auto r = j.recover(50);
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_EQ(r->replayed_records, 20u);
        expectHistory(r->history, 150);
    }
    {
        Journal j = openJournal();
        auto r = j.recover(0);
        ASSERT_TRUE(r.ok()) << r.error().message;
        expectHistory(r->history, 200);
    }
    // the older segment damaged: recovery does not need it, the history stops at the snapshot
    const auto older = filesStartingWith(dir_, "journal-").front();
    auto bytes = readBytes(older);
    bytes[recordOffset(10) + 20] ^= 0x01;
    writeBytes(older, bytes);
    {
        Journal j = openJournal();
        auto r = j.recover(50);
        ASSERT_TRUE(r.ok()) << r.error().message;
        expectHistory(r->history, 180);
        ASSERT_FALSE(r->notes.empty());
        EXPECT_TRUE(contains(r->notes.back(), "history stops before journal-00000000000000000121"))
            << r->notes.back();
    }
    // a clean stop writes a snapshot at the last seq and replays nothing: the history comes
    // from the segments before it (121 ... 180 is pruned with snapshot 120)
    {
        Journal j = openJournal({Durability::kFsync, 2});
        auto r = j.recover();
        ASSERT_TRUE(r.ok()) << r.error().message;
        ASSERT_TRUE(j.writeSnapshot(r->terrain, 200).ok());
    }
    {
        Journal j = openJournal();
        auto r = j.recover(50);
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_EQ(r->replayed_records, 0u);
        expectHistory(r->history, 181); // record 181 gives its hash to the base state
    }
}

TEST_F(JournalTest, historyRecordsKeepTheSegmentsAFullHistoryNeedsAfterACleanStop) {
    {
        Journal j = openJournal({Durability::kFsync, 2, 50});
        ASSERT_TRUE(j.initialize(genesis_).ok());
        for (std::uint64_t at : {60u, 120u, 180u, 200u}) {
            journalOps(j, at);
            ASSERT_TRUE(j.writeSnapshot(live_, at).ok()); // 200: the clean stop's
        }
    }
    // snapshot 180 alone would let 121 ... 180 go; 50 records before 200 need it
    EXPECT_EQ(
        filesStartingWith(dir_, "journal-").front().filename(), "journal-00000000000000000121.tjl");
    Journal j = openJournal();
    auto r = j.recover(50);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->replayed_records, 0u);
    EXPECT_EQ(r->history.base_seq, 150u);
    EXPECT_EQ(r->history.base_hash, hashes_[150]);
    ASSERT_EQ(r->history.records.size(), 50u);
    EXPECT_EQ(r->history.records.front().seq, 151u);
    EXPECT_EQ(r->history.records.back().world_hash, hashes_[200]);
}

TEST_F(JournalTest, aSnapshotWrittenInHalvesLetsRecordsFollowMeanwhile) {
    // the server's way: beginSnapshot, records appended while the file is written elsewhere,
    // then snapshotWritten; and a crash before the file exists
    {
        Journal j = openJournal({Durability::kFsync, 2});
        ASSERT_TRUE(j.initialize(genesis_).ok());
        journalOps(j, 60);
        ASSERT_TRUE(j.beginSnapshot(60).ok());
        const Terrain at60 = live_;
        journalOps(j, 75); // go on while the file is being written
        ASSERT_TRUE(writeSnapshotFile(dir_, at60, 60).ok());
        ASSERT_TRUE(j.snapshotWritten(Ok{}).ok());
        EXPECT_EQ(j.stats().snapshots_written, 2u); // the genesis and this one
        journalOps(j, 90);
        ASSERT_TRUE(j.beginSnapshot(90).ok()); // never written: the process dies here
        journalOps(j, 100);
        // a failed write leaves the journal usable
        EXPECT_FALSE(j.snapshotWritten(makeError(ErrorCode::kIo, "disk full")).ok());
        EXPECT_EQ(j.failure(), nullptr);
        journalOps(j, 110);
    }
    EXPECT_EQ(
        filesStartingWith(dir_, "journal-").back().filename(), "journal-00000000000000000091.tjl");
    auto r = recoverFresh();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->snapshot_seq, 60u);
    EXPECT_EQ(r->replayed_records, 50u);
    EXPECT_EQ(r->seq, 110u);
    EXPECT_EQ(r->terrain.worldHash(), live_.worldHash());
    auto verified = verifyJournal(dir_);
    ASSERT_TRUE(verified.ok()) << verified.error().message;
    EXPECT_EQ(verified->last_seq, 110u);
}

TEST_F(JournalTest, keepOneSnapshotPrunesEverySegmentBeforeIt) {
    Journal j = openJournal({Durability::kFsync, 1});
    ASSERT_TRUE(j.initialize(genesis_).ok());
    journalOps(j, 50);
    ASSERT_TRUE(j.writeSnapshot(live_, 50).ok());
    EXPECT_EQ(filesStartingWith(dir_, "snapshot-").size(), 1u);
    ASSERT_EQ(filesStartingWith(dir_, "journal-").size(), 1u);
    EXPECT_EQ(
        filesStartingWith(dir_, "journal-")[0].filename(), "journal-00000000000000000051.tjl");
}

TEST_F(JournalTest, tornLastRecordIsDroppedAndAppendingContinues) {
    struct Damage {
        const char* what;
        std::size_t cut;  // bytes removed from the end
        std::size_t flip; // byte of the last record to flip, or kRecordSize for none
    };
    for (const Damage d :
         {Damage{"cut 1", 1, kRecordSize}, Damage{"cut 20", 20, kRecordSize},
          Damage{"cut 56", kRecordSize - 1, kRecordSize}, Damage{"flip magic", 0, 0},
          Damage{"flip op", 0, 20}, Damage{"flip checksum", 0, kRecordSize - 1}}) {
        SCOPED_TRACE(d.what);
        fs::remove_all(dir_);
        live_ = genesis_;
        live_seq_ = 0;
        makeJournal(30);
        const auto segment = filesStartingWith(dir_, "journal-").at(0);
        auto bytes = readBytes(segment);
        if (d.flip < kRecordSize)
            bytes[recordOffset(29) + d.flip] ^= 0x01;
        bytes.resize(bytes.size() - d.cut);
        writeBytes(segment, bytes);
        {
            Journal j = openJournal();
            auto r = j.recover();
            ASSERT_TRUE(r.ok()) << r.error().message;
            EXPECT_EQ(r->seq, 29u);
            EXPECT_EQ(r->replayed_records, 29u);
            EXPECT_EQ(r->torn_bytes_dropped, kRecordSize - d.cut);
            EXPECT_EQ(r->terrain.worldHash(), hashes_[29]);
            EXPECT_EQ(fs::file_size(segment), recordOffset(29));
            // the record that was torn is appended again, and recovery sees it
            j.append({30, ops_[29], hashes_[30]});
            ASSERT_TRUE(j.commit().ok());
        }
        auto again = recoverFresh();
        ASSERT_TRUE(again.ok()) << again.error().message;
        EXPECT_EQ(again->seq, 30u);
        EXPECT_EQ(again->torn_bytes_dropped, 0u);
        EXPECT_EQ(again->terrain.worldHash(), hashes_[30]);
    }
}

TEST_F(JournalTest, aTornGroupCommitOfSeveralRecordsIsDropped) {
    makeJournal(30);
    const auto segment = filesStartingWith(dir_, "journal-").at(0);
    auto bytes = readBytes(segment);
    bytes.resize(bytes.size() + 3 * kRecordSize + 11, 0); // zero-filled pages after a crash
    writeBytes(segment, bytes);
    auto r = recoverFresh();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->seq, 30u);
    EXPECT_EQ(r->torn_bytes_dropped, 3 * kRecordSize + 11);
    auto v = verifyJournal(dir_);
    ASSERT_TRUE(v.ok()) << v.error().message;
    EXPECT_EQ(v->torn_bytes, 0u); // recovery truncated it
}

TEST_F(JournalTest, corruptionFollowedByValidRecordsIsRefused) {
    makeJournal(30);
    const auto segment = filesStartingWith(dir_, "journal-").at(0);
    const auto good = readBytes(segment);
    for (std::size_t record : {0u, 10u, 28u}) {
        SCOPED_TRACE(record);
        auto bytes = good;
        bytes[recordOffset(record) + 30] ^= 0x08;
        writeBytes(segment, bytes);
        auto r = recoverFresh();
        ASSERT_FALSE(r.ok());
        EXPECT_EQ(r.error().code, ErrorCode::kBadFormat);
        const std::string& m = r.error().message;
        EXPECT_TRUE(contains(m, "journal-00000000000000000001.tjl")) << m;
        EXPECT_TRUE(contains(m, "offset " + std::to_string(recordOffset(record)))) << m;
        EXPECT_TRUE(contains(m, "checksum")) << m;
        EXPECT_TRUE(contains(m, "followed by a valid record")) << m;
        EXPECT_EQ(readBytes(segment), bytes); // a refused recovery writes nothing
        auto v = verifyJournal(dir_);
        ASSERT_FALSE(v.ok());
        EXPECT_EQ(v.error().message, m);
    }
    // inserted bytes shift the later records off their boundaries; they are still found
    auto bytes = good;
    bytes.insert(bytes.begin() + recordOffset(20), 5, 0);
    writeBytes(segment, bytes);
    auto shifted = recoverFresh();
    ASSERT_FALSE(shifted.ok());
    EXPECT_TRUE(contains(
        shifted.error().message,
        "followed by a valid record at offset " + std::to_string(recordOffset(20) + 5)))
        << shifted.error().message;
    // a bad segment header
    bytes = good;
    bytes[2] = 'X';
    writeBytes(segment, bytes);
    auto h = recoverFresh();
    ASSERT_FALSE(h.ok());
    EXPECT_TRUE(contains(h.error().message, "offset 0: not a journal segment"))
        << h.error().message;
}

TEST_F(JournalTest, aRecordWithAWrongWorldHashIsRefusedNamingItsSeq) {
    {
        Journal j = openJournal();
        ASSERT_TRUE(j.initialize(genesis_).ok());
        journalOps(j, 14);
        ASSERT_TRUE(live_.apply(ops_[14]).ok());
        j.append({15, ops_[14], live_.worldHash() ^ 1}); // checksum valid, hash wrong
        ++live_seq_;
        ASSERT_TRUE(j.commit().ok());
        journalOps(j, 30);
    }
    auto r = recoverFresh();
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kHashMismatch);
    EXPECT_TRUE(contains(r.error().message, "seq 15:")) << r.error().message;
    auto v = verifyJournal(dir_);
    ASSERT_FALSE(v.ok());
    EXPECT_EQ(v.error().code, ErrorCode::kHashMismatch);
    EXPECT_TRUE(contains(v.error().message, "seq 15:")) << v.error().message;
}

TEST_F(JournalTest, verifyAgreesWithTheLiveHashAtEverySeq) {
    {
        Journal j = openJournal({Durability::kFsync, 3});
        ASSERT_TRUE(j.initialize(genesis_).ok());
        journalOps(j, 70);
        ASSERT_TRUE(j.writeSnapshot(live_, 70).ok());
        journalOps(j, 140);
        ASSERT_TRUE(j.writeSnapshot(live_, 140).ok());
        journalOps(j, 200);
    }
    auto v = verifyJournal(dir_);
    ASSERT_TRUE(v.ok()) << v.error().message;
    EXPECT_EQ(v->base_seq, 0u);
    EXPECT_EQ(v->last_seq, 200u);
    EXPECT_EQ(v->records_checked, 200u);
    EXPECT_EQ(v->segments_checked, 3u);
    EXPECT_EQ(v->snapshots_checked, 3u);
    EXPECT_EQ(v->final_hash, live_.worldHash());
    EXPECT_EQ(v->torn_bytes, 0u);
    // every record carries the hash the live terrain had at its seq
    std::uint64_t seq = 0;
    for (const auto& segment : filesStartingWith(dir_, "journal-")) {
        const auto bytes = readBytes(segment);
        for (std::size_t at = kSegmentHeaderSize; at < bytes.size(); at += kRecordSize) {
            auto r = decodeRecord(std::span(bytes).subspan(at));
            ASSERT_TRUE(r.ok()) << r.error().message;
            ASSERT_EQ(r->seq, ++seq);
            EXPECT_EQ(r->world_hash, hashes_[seq]) << seq;
        }
    }
    EXPECT_EQ(seq, 200u);
}

TEST_F(JournalTest, verifyDetectsTamperedRecordsSeqsAndSnapshots) {
    {
        Journal j = openJournal({Durability::kWrite, 3});
        ASSERT_TRUE(j.initialize(genesis_).ok());
        journalOps(j, 40);
        ASSERT_TRUE(j.writeSnapshot(live_, 40).ok());
        journalOps(j, 60);
    }
    ASSERT_TRUE(verifyJournal(dir_).ok());
    const auto first = filesStartingWith(dir_, "journal-").at(0);
    const auto good = readBytes(first);
    // rewrites record `index` of the first segment with a valid checksum
    auto forge = [&](std::size_t index, auto change) {
        auto bytes = good;
        auto r = decodeRecord(std::span(bytes).subspan(recordOffset(index)));
        EXPECT_TRUE(r.ok());
        JournalRecord rec = *r;
        change(rec);
        std::vector<std::uint8_t> enc;
        appendRecord(rec, enc);
        std::copy(enc.begin(), enc.end(), bytes.begin() + recordOffset(index));
        writeBytes(first, bytes);
        return verifyJournal(dir_);
    };
    auto op = forge(9, [](JournalRecord& r) { r.op.radius += 1; });
    ASSERT_FALSE(op.ok());
    EXPECT_EQ(op.error().code, ErrorCode::kHashMismatch);
    EXPECT_TRUE(contains(op.error().message, "seq 10:")) << op.error().message;
    auto hash = forge(30, [](JournalRecord& r) { r.world_hash ^= 0x100; });
    ASSERT_FALSE(hash.ok());
    EXPECT_EQ(hash.error().code, ErrorCode::kHashMismatch);
    EXPECT_TRUE(contains(hash.error().message, "seq 31:")) << hash.error().message;
    auto gap = forge(5, [](JournalRecord& r) { r.seq += 1; });
    ASSERT_FALSE(gap.ok());
    EXPECT_EQ(gap.error().code, ErrorCode::kBadFormat);
    EXPECT_TRUE(contains(gap.error().message, "record seq 7, expected 6")) << gap.error().message;
    auto invalid = forge(3, [](JournalRecord& r) { r.op.kind = static_cast<OpKind>(9); });
    ASSERT_FALSE(invalid.ok());
    EXPECT_TRUE(contains(invalid.error().message, "seq 4: op refused")) << invalid.error().message;
    // bad bytes at the end of a segment that is not the newest are not a torn write
    auto cut = good;
    cut.resize(cut.size() - 3);
    writeBytes(first, cut);
    auto old = verifyJournal(dir_);
    ASSERT_FALSE(old.ok());
    EXPECT_TRUE(contains(old.error().message, "not the newest")) << old.error().message;
    writeBytes(first, good);
    ASSERT_TRUE(verifyJournal(dir_).ok());

    // a later snapshot that disagrees with the replay
    const auto snapshot = dir_ / "snapshot-00000000000000000040.trsn";
    writeBytes(snapshot, encodeSnapshot(genesis_, 40));
    auto snap = verifyJournal(dir_);
    ASSERT_FALSE(snap.ok());
    EXPECT_EQ(snap.error().code, ErrorCode::kHashMismatch);
    EXPECT_TRUE(contains(snap.error().message, "snapshot-00000000000000000040.trsn"));
    // a missing segment is a gap
    writeBytes(snapshot, encodeSnapshot(live_, 40)); // wrong state, but not read below
    fs::remove(first);
    auto missing = verifyJournal(dir_);
    ASSERT_FALSE(missing.ok());
    EXPECT_TRUE(contains(missing.error().message, "missing")) << missing.error().message;
}

TEST_F(JournalTest, recoveryContinuesTheOldSegmentWhenACrashLeftOnlyTheSnapshot) {
    {
        Journal j = openJournal();
        ASSERT_TRUE(j.initialize(genesis_).ok());
        journalOps(j, 10);
        ASSERT_TRUE(j.writeSnapshot(live_, 10).ok());
    }
    // the crash came after the snapshot's rename and before the new segment's
    fs::remove(dir_ / "journal-00000000000000000011.tjl");
    writeBytes(dir_ / "journal-00000000000000000011.tjl.tmp", {1, 2, 3});
    {
        Journal j = openJournal();
        auto r = j.recover();
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_EQ(r->seq, 10u);
        EXPECT_EQ(r->snapshot_seq, 10u);
        EXPECT_EQ(r->replayed_records, 0u);
        EXPECT_FALSE(fs::exists(dir_ / "journal-00000000000000000011.tjl.tmp"));
        journalOps(j, 15);
    }
    // seq 11 follows seq 10 in the segment that holds it, so no new segment is needed
    ASSERT_EQ(filesStartingWith(dir_, "journal-").size(), 1u);
    EXPECT_EQ(fs::file_size(dir_ / "journal-00000000000000000001.tjl"), recordOffset(15));
    auto r = recoverFresh();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->seq, 15u);
    EXPECT_EQ(r->terrain.worldHash(), live_.worldHash());
    auto v = verifyJournal(dir_);
    ASSERT_TRUE(v.ok()) << v.error().message;
    EXPECT_EQ(v->last_seq, 15u);
    EXPECT_EQ(v->snapshots_checked, 2u);
}

TEST_F(JournalTest, recoveryStartsASegmentWhenTheSnapshotHasNone) {
    {
        Journal j = openJournal();
        ASSERT_TRUE(j.initialize(genesis_, 7).ok());
    }
    // the crash came between initialize()'s snapshot and its segment
    fs::remove(dir_ / "journal-00000000000000000008.tjl");
    {
        Journal j = openJournal();
        auto r = j.recover();
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_EQ(r->seq, 7u);
        ASSERT_FALSE(r->notes.empty());
        EXPECT_TRUE(contains(r->notes.back(), "started journal-00000000000000000008.tjl"));
        ASSERT_TRUE(live_.apply(ops_[0]).ok());
        j.append({8, ops_[0], live_.worldHash()});
        ASSERT_TRUE(j.commit().ok());
    }
    auto r = recoverFresh();
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->seq, 8u);
    EXPECT_EQ(r->terrain.worldHash(), live_.worldHash());
}

} // namespace
} // namespace terrain::journal
