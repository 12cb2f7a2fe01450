#include <terrain/server/auth_token.h>

// HMAC: RFC 2104, through OpenSSL 3's EVP_Q_mac (the one-shot HMAC() is deprecated in 3.0).
// Test vectors: RFC 4231.

#include <terrain/assert.h>

#include <openssl/crypto.h>
#include <openssl/evp.h>

#include <cstdlib>
#include <limits>
#include <ostream>

namespace terrain::server {

namespace {

constexpr std::string_view kVersion = "v1";
constexpr std::size_t kFieldCount = 5;
constexpr std::size_t kMacHexDigits = 64;
constexpr char kHexDigits[] = "0123456789abcdef";

bool isDigit(char c) {
    return c >= '0' && c <= '9';
}

/// Value of one hex digit, or -1. Lowercase only unless `allow_upper`.
int hexValue(char c, bool allow_upper) {
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (allow_upper && c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

std::string toHex(std::span<const std::uint8_t> bytes) {
    std::string out;
    out.reserve(bytes.size() * 2);
    for (const std::uint8_t b : bytes) {
        out.push_back(kHexDigits[b >> 4]);
        out.push_back(kHexDigits[b & 0x0f]);
    }
    return out;
}

/// Canonical unsigned decimal: 1+ digits, no sign, no leading zero (except "0").
/// `what` names the field in the message.
Result<std::uint64_t>
parseCanonicalDecimal(std::string_view text, std::uint64_t max, const char* what) {
    if (text.empty())
        return makeError(ErrorCode::kBadFormat, std::string(what) + " is empty");
    for (const char c : text) {
        if (!isDigit(c))
            return makeError(
                ErrorCode::kBadFormat, std::string(what) + " must be plain decimal digits");
    }
    if (text.size() > 1 && text.front() == '0')
        return makeError(ErrorCode::kBadFormat, std::string(what) + " has a leading zero");
    std::uint64_t value = 0;
    for (const char c : text) {
        const auto digit = static_cast<std::uint64_t>(c - '0');
        if (value > (max - digit) / 10)
            return makeError(
                ErrorCode::kOutOfRange, std::string(what) + " exceeds " + std::to_string(max));
        value = value * 10 + digit;
    }
    return value;
}

std::string signingInput(const TokenClaims& claims) {
    std::string s(kVersion);
    s += '.';
    s += std::to_string(claims.player_id);
    s += '.';
    s += toString(claims.role);
    s += '.';
    s += std::to_string(claims.expires_unix);
    return s;
}

} // namespace

const char* toString(Role role) {
    switch (role) {
    case Role::kViewer:
        return "viewer";
    case Role::kDeformer:
        return "deformer";
    case Role::kAdmin:
        return "admin";
    }
    return "unknown";
}

Result<Role> parseRole(std::string_view name) {
    for (const Role r : {Role::kViewer, Role::kDeformer, Role::kAdmin}) {
        if (name == toString(r))
            return r;
    }
    return makeError(ErrorCode::kBadFormat, "unknown role (expected viewer, deformer or admin)");
}

bool mayDeform(Role role) {
    return role == Role::kDeformer || role == Role::kAdmin;
}

bool mayAdminister(Role role) {
    return role == Role::kAdmin;
}

std::ostream& operator<<(std::ostream& out, Role role) {
    return out << toString(role);
}

std::ostream& operator<<(std::ostream& out, const TokenClaims& claims) {
    return out << "{player " << claims.player_id << ", " << claims.role << ", expires "
               << claims.expires_unix << "}";
}

std::array<std::uint8_t, 32>
hmacSha256(std::span<const std::uint8_t> key, std::string_view message) {
    // note: an empty span may have a null data(); give OpenSSL a valid pointer either way
    static constexpr std::uint8_t kEmpty[1] = {0};
    const void* key_ptr = key.empty() ? kEmpty : key.data();
    const auto* msg_ptr = reinterpret_cast<const unsigned char*>(message.data());
    std::array<std::uint8_t, 32> mac{};
    std::size_t mac_len = 0;
    const unsigned char* done = EVP_Q_mac(
        nullptr, "HMAC", nullptr, "SHA256", nullptr, key_ptr, key.size(),
        message.empty() ? kEmpty : msg_ptr, message.size(), mac.data(), mac.size(), &mac_len);
    if (done == nullptr || mac_len != mac.size()) {
        // fail closed: a zero or partial MAC would let forged tokens through
        std::abort();
    }
    return mac;
}

std::string mintToken(const TokenClaims& claims, std::span<const std::uint8_t> secret) {
    TERRAIN_ASSERT(secret.size() >= kMinSecretBytes);
    TERRAIN_ASSERT(parseRole(toString(claims.role)).ok());
    TERRAIN_ASSERT(claims.expires_unix >= 0);
    std::string token = signingInput(claims);
    const auto mac = hmacSha256(secret, token);
    token += '.';
    token += toHex(mac);
    return token;
}

Result<TokenClaims>
verifyToken(std::string_view token, std::span<const std::uint8_t> secret, std::int64_t now_unix) {
    if (secret.size() < kMinSecretBytes)
        return makeError(
            ErrorCode::kOutOfRange,
            "server secret is shorter than " + std::to_string(kMinSecretBytes) + " bytes");
    if (token.empty())
        return makeError(ErrorCode::kBadFormat, "token is empty");
    if (token.size() > kMaxTokenLength)
        return makeError(
            ErrorCode::kOutOfRange,
            "token is longer than " + std::to_string(kMaxTokenLength) + " characters");

    // version first: another version may have another layout
    const std::string_view version = token.substr(0, token.find('.'));
    if (version != kVersion) {
        const bool looks_versioned =
            version.size() >= 2 && version.front() == 'v' &&
            version.find_first_not_of("0123456789", 1) == std::string_view::npos;
        if (looks_versioned)
            return makeError(
                ErrorCode::kUnsupported,
                "token version " + std::string(version) + " is not supported (expected v1)");
        return makeError(ErrorCode::kBadFormat, "token does not start with version v1");
    }

    std::array<std::string_view, kFieldCount> fields;
    std::size_t count = 0;
    std::size_t start = 0;
    while (true) {
        const std::size_t dot = token.find('.', start);
        if (count == kFieldCount)
            return makeError(ErrorCode::kBadFormat, "token must have exactly 5 fields");
        fields[count++] = token.substr(start, dot == std::string_view::npos ? dot : dot - start);
        if (dot == std::string_view::npos)
            break;
        start = dot + 1;
    }
    if (count != kFieldCount)
        return makeError(ErrorCode::kBadFormat, "token must have exactly 5 fields");

    const std::string_view mac_hex = fields[4];
    std::array<std::uint8_t, 32> mac{};
    if (mac_hex.size() != kMacHexDigits)
        return makeError(ErrorCode::kBadFormat, "signature must be 64 lowercase hex digits");
    for (std::size_t i = 0; i < mac.size(); ++i) {
        const int hi = hexValue(mac_hex[2 * i], false);
        const int lo = hexValue(mac_hex[2 * i + 1], false);
        if (hi < 0 || lo < 0)
            return makeError(ErrorCode::kBadFormat, "signature must be 64 lowercase hex digits");
        mac[i] = static_cast<std::uint8_t>(hi * 16 + lo);
    }

    // authenticate before parsing: the signed text is everything before the last dot
    const std::string_view signed_part = token.substr(0, token.size() - kMacHexDigits - 1);
    const auto expected = hmacSha256(secret, signed_part);
    if (CRYPTO_memcmp(expected.data(), mac.data(), mac.size()) != 0)
        return makeError(ErrorCode::kHashMismatch, "token signature does not match");

    auto player_id =
        parseCanonicalDecimal(fields[1], std::numeric_limits<std::uint64_t>::max(), "player id");
    if (!player_id)
        return player_id.error();
    auto role = parseRole(fields[2]);
    if (!role)
        return role.error();
    auto expiry = parseCanonicalDecimal(
        fields[3], static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()), "expiry");
    if (!expiry)
        return expiry.error();

    TokenClaims claims;
    claims.player_id = *player_id;
    claims.role = *role;
    claims.expires_unix = static_cast<std::int64_t>(*expiry);
    if (claims.expires_unix <= now_unix)
        return makeError(ErrorCode::kOutOfRange, "token expired");
    return claims;
}

Result<std::vector<std::uint8_t>> parseSecret(std::string_view hex_or_text) {
    constexpr std::string_view kHexPrefix = "hex:";
    std::vector<std::uint8_t> bytes;
    if (hex_or_text.starts_with(kHexPrefix)) {
        const std::string_view digits = hex_or_text.substr(kHexPrefix.size());
        if (digits.size() % 2 != 0)
            return makeError(ErrorCode::kBadFormat, "hex secret has an odd number of digits");
        // note: check the size before decoding so a huge value is never copied
        if (digits.size() / 2 > kMaxSecretBytes)
            return makeError(
                ErrorCode::kOutOfRange,
                "secret is longer than " + std::to_string(kMaxSecretBytes) + " bytes");
        bytes.reserve(digits.size() / 2);
        for (std::size_t i = 0; i < digits.size(); i += 2) {
            const int hi = hexValue(digits[i], true);
            const int lo = hexValue(digits[i + 1], true);
            if (hi < 0 || lo < 0)
                return makeError(
                    ErrorCode::kBadFormat, "hex secret contains a character that is not hex");
            bytes.push_back(static_cast<std::uint8_t>(hi * 16 + lo));
        }
    } else {
        if (hex_or_text.size() > kMaxSecretBytes)
            return makeError(
                ErrorCode::kOutOfRange,
                "secret is longer than " + std::to_string(kMaxSecretBytes) + " bytes");
        constexpr std::string_view kSpace = " \t\r\n\v\f";
        if (!hex_or_text.empty() && (kSpace.find(hex_or_text.front()) != std::string_view::npos ||
                                     kSpace.find(hex_or_text.back()) != std::string_view::npos))
            return makeError(
                ErrorCode::kBadFormat, "secret text has leading or trailing whitespace");
        bytes.assign(hex_or_text.begin(), hex_or_text.end());
    }
    if (bytes.size() < kMinSecretBytes)
        return makeError(
            ErrorCode::kOutOfRange,
            "secret is shorter than " + std::to_string(kMinSecretBytes) + " bytes");
    return bytes;
}

} // namespace terrain::server
