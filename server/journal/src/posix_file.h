#pragma once

// The journal's I/O edge: thin POSIX wrappers that retry EINTR and partial writes and turn every
// failure into a kIo error naming the file and errno's text. Private to terrain_journal.

#include <terrain/result.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

namespace terrain::journal::detail {

/// Owns one file descriptor; closes it on destruction. Move-only.
class FileHandle {
  public:
    FileHandle() = default;
    explicit FileHandle(int fd) : fd_(fd) {}
    FileHandle(FileHandle&& other) noexcept : fd_(other.release()) {}
    FileHandle& operator=(FileHandle&& other) noexcept;
    FileHandle(const FileHandle&) = delete;
    FileHandle& operator=(const FileHandle&) = delete;
    ~FileHandle();

    int get() const { return fd_; }
    bool valid() const { return fd_ >= 0; }
    int release() {
        const int fd = fd_;
        fd_ = -1;
        return fd;
    }

  private:
    int fd_ = -1;
};

/// open(2) with O_CLOEXEC added. Errors: kIo.
Result<FileHandle> openFile(const std::filesystem::path& path, int flags, unsigned mode = 0644);

/// Reads the whole file. Errors: kIo.
Result<std::vector<std::uint8_t>> readWholeFile(const std::filesystem::path& path);

/// Writes every byte, retrying EINTR and short writes. `path` only names the file in errors.
/// Errors: kIo (the file may then hold a prefix of `bytes`).
Status writeAll(int fd, std::span<const std::uint8_t> bytes, const std::filesystem::path& path);

/// fdatasync(2). Errors: kIo; after one the file's state on disk is unknown (do not retry).
Status syncData(int fd, const std::filesystem::path& path);

/// fsync(2) of a directory, so that creations, renames and removals in it are durable.
/// Errors: kIo.
Status syncDirectory(const std::filesystem::path& dir);

/// A file written atomically and durably, in pieces: a temp file of its own
/// (`path`.<n>.tmp), append() as often as needed, then commit(): fdatasync, rename, fsync of the
/// directory. A crash leaves either the old file (or none) or the complete new one, plus perhaps
/// a stale temp file; one dropped before commit() removes its temp file.
/// The pieces go to the disk as they come (sync_file_range on Linux, at most two pieces in
/// flight), so that the last fdatasync has little left to write: on ext4 a snapshot's tens of
/// MB flushed at once held up the journal's own writes and syncs for 20-40 ms.
class AtomicFileWriter {
  public:
    /// Creates the temp file. Errors: kIo.
    static Result<AtomicFileWriter> create(std::filesystem::path path);
    /// Errors: kIo (the writer is then spent: commit() returns the same error).
    Status append(std::span<const std::uint8_t> bytes);
    /// Errors: kIo.
    Status commit();

    AtomicFileWriter(AtomicFileWriter&& other) noexcept;
    AtomicFileWriter& operator=(AtomicFileWriter&&) = delete;
    AtomicFileWriter(const AtomicFileWriter&) = delete;
    AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
    ~AtomicFileWriter();

  private:
    AtomicFileWriter(std::filesystem::path path, std::filesystem::path temp, FileHandle file)
        : path_(std::move(path)), temp_(std::move(temp)), file_(std::move(file)) {}

    std::filesystem::path path_;
    std::filesystem::path temp_;
    FileHandle file_;
    std::uint64_t written_ = 0;      // bytes appended
    std::uint64_t flushed_from_ = 0; // start of the range whose writeback is not waited for yet
    std::optional<Error> failure_;
    bool owns_temp_ = true; // false once committed or moved from
};

/// One AtomicFileWriter append. Errors: kIo.
Status writeFileAtomically(const std::filesystem::path& path, std::span<const std::uint8_t> bytes);

/// Shrinks the file to `size` bytes and fdatasyncs it. Errors: kIo.
Status truncateFile(const std::filesystem::path& path, std::size_t size);

/// unlink(2); a missing file is not an error. Errors: kIo.
Status removeFile(const std::filesystem::path& path);

/// Takes an exclusive advisory lock (flock) on `path`, creating it if needed, and returns the
/// descriptor that holds it. Errors: kIo, also when another descriptor already holds the lock.
Result<FileHandle> lockFile(const std::filesystem::path& path);

} // namespace terrain::journal::detail
