#pragma once

// Access tokens: a player id, a role and an expiry, signed with HMAC-SHA256 under a server
// secret. Pure: no globals, no clocks, no I/O; the caller passes the time in.
// Entry points: mintToken, verifyToken, parseSecret, hmacSha256.
//
// Token text (ASCII, at most kMaxTokenLength characters):
//
//     v1.<player_id>.<role>.<expires_unix>.<mac>
//
//   player_id     decimal uint64, canonical: no sign, no leading zeros ("0" itself is allowed)
//   role          "viewer" | "deformer" | "admin"
//   expires_unix  decimal int64 >= 0, canonical like player_id; seconds since the Unix epoch
//   mac           64 lowercase hex digits of HMAC-SHA256(secret, "v1.<player_id>.<role>.<expiry>")
//
// Every token has exactly one accepted spelling, so a token can be compared, logged or
// revoked as a string.

#include <terrain/result.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace terrain::server {

/// What a session may do. Each role includes the rights of the roles below it.
enum class Role : std::uint8_t {
    kViewer = 1,   ///< receives the world and its ops; may not request ops
    kDeformer = 2, ///< may also request deformation ops
    kAdmin = 3,    ///< may do everything, including forcing snapshots and other operator commands
};

/// "viewer", "deformer" or "admin"; "unknown" for a value outside the enum.
const char* toString(Role role);

/// Inverse of toString(Role), exact and case-sensitive.
/// Fails with kBadFormat ("unknown role") for any other text.
Result<Role> parseRole(std::string_view name);

/// True for kDeformer and kAdmin. False for kViewer and for any value outside the enum.
bool mayDeform(Role role);

/// True for kAdmin only (force snapshots and other operator commands).
bool mayAdminister(Role role);

struct TokenClaims {
    std::uint64_t player_id = 0;
    Role role = Role::kViewer;
    std::int64_t expires_unix = 0; ///< seconds since the Unix epoch; valid while now < expiry

    friend bool operator==(const TokenClaims&, const TokenClaims&) = default;
};

std::ostream& operator<<(std::ostream& out, Role role);
std::ostream& operator<<(std::ostream& out, const TokenClaims& claims);

/// Longest token verifyToken looks at. A valid v1 token is at most 117 characters.
inline constexpr std::size_t kMaxTokenLength = 256;
/// Shortest secret accepted by parseSecret, mintToken and verifyToken.
inline constexpr std::size_t kMinSecretBytes = 16;
/// Longest secret accepted by parseSecret.
inline constexpr std::size_t kMaxSecretBytes = 1024;

/// HMAC-SHA256 (RFC 2104 with SHA-256) of `message` under `key`; any key length, including 0.
/// IMPORTANT: aborts if OpenSSL cannot compute an HMAC at all (a broken installation): a
/// signature check must fail closed, never fall back to a predictable value.
std::array<std::uint8_t, 32>
hmacSha256(std::span<const std::uint8_t> key, std::string_view message);

/// Signs `claims` into a token in the format above.
/// Preconditions (bugs if broken, TERRAIN_ASSERT): `secret` has at least kMinSecretBytes,
/// `claims.role` is a Role enumerator and `claims.expires_unix >= 0`.
std::string mintToken(const TokenClaims& claims, std::span<const std::uint8_t> secret);

/// Checks an untrusted token and returns its claims. Never throws, never asserts on `token`.
/// The signature is checked before the fields are parsed, so the field parser only ever sees
/// text this server signed. Rules, in the order they are checked:
///   - kOutOfRange   `secret` shorter than kMinSecretBytes (then nothing is ever accepted)
///   - kBadFormat    empty token
///   - kOutOfRange   token longer than kMaxTokenLength
///   - kUnsupported  a version other than v1 ("v" followed by digits, e.g. "v2")
///   - kBadFormat    no "v1" version field
///   - kBadFormat    not exactly 5 dot-separated fields
///   - kBadFormat    signature field not 64 lowercase hex digits
///   - kHashMismatch signature does not match (constant-time compare): wrong secret or edited
///   - kBadFormat    player id or expiry empty, not plain decimal digits, or with leading zeros
///   - kOutOfRange   player id above 2^64-1, or expiry above 2^63-1
///   - kBadFormat    unknown role
///   - kOutOfRange   "token expired": expires_unix <= now_unix
/// Each message names the rule.
Result<TokenClaims>
verifyToken(std::string_view token, std::span<const std::uint8_t> secret, std::int64_t now_unix);

/// Reads the server secret from configuration text (untrusted).
///   - "hex:<digits>": an even number of hex digits (either case), decoded to bytes;
///   - anything else: the text's bytes, as-is.
/// Failures:
///   - kBadFormat  odd number of hex digits, or a non-hex character after "hex:"
///   - kBadFormat  raw text with leading or trailing whitespace (usually a stray newline from a
///                 secret file: strip it before calling, or use the hex form)
///   - kOutOfRange fewer than kMinSecretBytes or more than kMaxSecretBytes bytes (after decoding)
Result<std::vector<std::uint8_t>> parseSecret(std::string_view hex_or_text);

} // namespace terrain::server
