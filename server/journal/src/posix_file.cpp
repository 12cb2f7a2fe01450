#include "posix_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

namespace terrain::journal::detail {
namespace {

Error ioError(const char* what, const std::filesystem::path& path, int err) {
    return makeError(
        ErrorCode::kIo, std::string(what) + " " + path.string() + ": " + std::strerror(err));
}

} // namespace

FileHandle& FileHandle::operator=(FileHandle&& other) noexcept {
    if (this != &other) {
        if (fd_ >= 0)
            ::close(fd_);
        fd_ = other.release();
    }
    return *this;
}

FileHandle::~FileHandle() {
    // note: close errors are ignored; durability comes from the explicit syncs, never from close
    if (fd_ >= 0)
        ::close(fd_);
}

Result<FileHandle> openFile(const std::filesystem::path& path, int flags, unsigned mode) {
    int fd = -1;
    do {
        fd = ::open(path.c_str(), flags | O_CLOEXEC, static_cast<mode_t>(mode));
    } while (fd < 0 && errno == EINTR);
    if (fd < 0)
        return ioError("cannot open", path, errno);
    return FileHandle(fd);
}

Result<std::vector<std::uint8_t>> readWholeFile(const std::filesystem::path& path) {
    auto file = openFile(path, O_RDONLY);
    if (!file)
        return file.error();
    struct stat st {};
    if (::fstat(file->get(), &st) != 0)
        return ioError("cannot stat", path, errno);
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(st.st_size));
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::read(file->get(), bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return ioError("cannot read", path, errno);
        if (n == 0)
            break; // the file shrank while we read it: keep what is there
        done += static_cast<std::size_t>(n);
    }
    bytes.resize(done);
    return bytes;
}

Status writeAll(int fd, std::span<const std::uint8_t> bytes, const std::filesystem::path& path) {
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return ioError("cannot write", path, errno);
        done += static_cast<std::size_t>(n);
    }
    return Ok{};
}

Status syncData(int fd, const std::filesystem::path& path) {
    // note: EINTR is retried; any other failure is final, since the kernel may already have
    // dropped the dirty pages it could not write (a retry would wrongly report success)
    int rc = 0;
    do {
        rc = ::fdatasync(fd);
    } while (rc != 0 && errno == EINTR);
    if (rc != 0)
        return ioError("cannot fdatasync", path, errno);
    return Ok{};
}

Status syncDirectory(const std::filesystem::path& dir) {
    auto handle = openFile(dir, O_RDONLY | O_DIRECTORY);
    if (!handle)
        return handle.error();
    int rc = 0;
    do {
        rc = ::fsync(handle->get());
    } while (rc != 0 && errno == EINTR);
    if (rc != 0)
        return ioError("cannot fsync directory", dir, errno);
    return Ok{};
}

Result<AtomicFileWriter> AtomicFileWriter::create(std::filesystem::path path) {
    // a temp file per writer: a shutdown's snapshot may be written beside the snapshot thread's
    // of the same seq, and the rename is atomic either way
    static std::atomic<std::uint64_t> next_temp{0};
    std::string suffix = std::to_string(next_temp.fetch_add(1));
    suffix.insert(suffix.begin(), '.');
    suffix.append(".tmp");
    std::filesystem::path temp = path;
    temp += suffix;
    auto file = openFile(temp, O_WRONLY | O_CREAT | O_TRUNC);
    if (!file)
        return file.error();
    return AtomicFileWriter(std::move(path), std::move(temp), std::move(*file));
}

Status AtomicFileWriter::append(std::span<const std::uint8_t> bytes) {
    if (failure_)
        return *failure_;
    if (Status s = writeAll(file_.get(), bytes, temp_); !s) {
        failure_ = s.error();
        return s;
    }
    written_ += bytes.size();
#ifdef __linux__
    // start the writeback of what is new, and wait for the range before it: a steady trickle
    // instead of one flush of everything at the end. Advice only: errors surface at the sync.
    constexpr std::uint64_t kFlushBytes = std::uint64_t{1} << 20;
    if (written_ - flushed_from_ >= 2 * kFlushBytes) {
        const std::uint64_t upto = written_ - kFlushBytes;
        (void)::sync_file_range(
            file_.get(), static_cast<off64_t>(flushed_from_),
            static_cast<off64_t>(upto - flushed_from_),
            SYNC_FILE_RANGE_WAIT_BEFORE | SYNC_FILE_RANGE_WRITE | SYNC_FILE_RANGE_WAIT_AFTER);
        (void)::sync_file_range(
            file_.get(), static_cast<off64_t>(upto), static_cast<off64_t>(written_ - upto),
            SYNC_FILE_RANGE_WRITE);
        flushed_from_ = upto;
    }
#endif
    return Ok{};
}

Status AtomicFileWriter::commit() {
    if (failure_)
        return *failure_;
    if (Status s = syncData(file_.get(), temp_); !s) {
        failure_ = s.error();
        return s;
    }
    file_ = FileHandle();
    if (::rename(temp_.c_str(), path_.c_str()) != 0) {
        failure_ = ioError("cannot rename to", path_, errno);
        return *failure_;
    }
    owns_temp_ = false;
    return syncDirectory(path_.parent_path());
}

AtomicFileWriter::AtomicFileWriter(AtomicFileWriter&& other) noexcept
    : path_(std::move(other.path_)), temp_(std::move(other.temp_)), file_(std::move(other.file_)),
      written_(other.written_), flushed_from_(other.flushed_from_),
      failure_(std::move(other.failure_)), owns_temp_(std::exchange(other.owns_temp_, false)) {}

AtomicFileWriter::~AtomicFileWriter() {
    if (owns_temp_) {
        file_ = FileHandle();
        (void)::unlink(temp_.c_str());
    }
}

Status writeFileAtomically(const std::filesystem::path& path, std::span<const std::uint8_t> bytes) {
    auto writer = AtomicFileWriter::create(path);
    if (!writer)
        return writer.error();
    if (Status s = writer->append(bytes); !s)
        return s;
    return writer->commit();
}

Status truncateFile(const std::filesystem::path& path, std::size_t size) {
    auto file = openFile(path, O_WRONLY);
    if (!file)
        return file.error();
    int rc = 0;
    do {
        rc = ::ftruncate(file->get(), static_cast<off_t>(size));
    } while (rc != 0 && errno == EINTR);
    if (rc != 0)
        return ioError("cannot truncate", path, errno);
    return syncData(file->get(), path);
}

Status removeFile(const std::filesystem::path& path) {
    if (::unlink(path.c_str()) != 0 && errno != ENOENT)
        return ioError("cannot remove", path, errno);
    return Ok{};
}

Result<FileHandle> lockFile(const std::filesystem::path& path) {
    auto file = openFile(path, O_RDWR | O_CREAT);
    if (!file)
        return file.error();
    int rc = 0;
    do {
        rc = ::flock(file->get(), LOCK_EX | LOCK_NB);
    } while (rc != 0 && errno == EINTR);
    if (rc != 0 && errno == EWOULDBLOCK)
        return makeError(
            ErrorCode::kIo, "journal directory is in use: " + path.string() +
                                " is locked by another process or Journal");
    if (rc != 0)
        return ioError("cannot lock", path, errno);
    return file;
}

} // namespace terrain::journal::detail
