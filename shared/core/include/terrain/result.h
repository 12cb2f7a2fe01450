#pragma once

#include <string>
#include <utility>
#include <variant>

namespace terrain {

/// The rule an input broke. Every refusal carries one of these plus a sentence naming the rule,
/// so a caller can both branch on it and show it to a person.
enum class ErrorCode : unsigned char {
    kNotFinite,       // NaN or infinity where a number was required
    kOutOfRange,      // a parameter outside its documented range
    kOutsideMap,      // a position not inside the map
    kBadFormat,       // bytes or text that do not follow the format
    kTruncated,       // fewer bytes than the format requires
    kSizeMismatch,    // sizes that disagree with each other
    kUnsupported,     // a valid but unsupported variant (version, sample type, ...)
    kInvariantBroken, // well-formed data that breaks a state invariant (e.g. a crack)
    kHashMismatch,    // state whose recomputed hash differs from the one it came with
    kIo,              // the environment failed (missing file, read error)
};

const char* toString(ErrorCode code);

struct Error {
    ErrorCode code;
    std::string message;
};

/// Value or Error. Small on purpose: no exceptions cross the core's API for untrusted input.
template <typename T> class Result {
  public:
    Result(T value) : v_(std::move(value)) {}
    Result(Error error) : v_(std::move(error)) {}

    bool ok() const { return v_.index() == 0; }
    explicit operator bool() const { return ok(); }

    T& value() & { return std::get<0>(v_); }
    const T& value() const& { return std::get<0>(v_); }
    T&& value() && { return std::get<0>(std::move(v_)); }
    T& operator*() & { return value(); }
    const T& operator*() const& { return value(); }
    T* operator->() { return &value(); }
    const T* operator->() const { return &value(); }

    const Error& error() const { return std::get<1>(v_); }

  private:
    std::variant<T, Error> v_;
};

/// Result for operations with no value.
struct Ok {};
using Status = Result<Ok>;

inline Error makeError(ErrorCode code, std::string message) {
    return Error{code, std::move(message)};
}

} // namespace terrain
