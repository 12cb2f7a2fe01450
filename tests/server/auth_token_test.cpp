#include <terrain/server/auth_token.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace terrain::server {
namespace {

constexpr std::int64_t kNow = 1'700'000'000; // non-zero time, as the core never reads a clock
constexpr std::int64_t kLater = kNow + 3600;

std::vector<std::uint8_t> bytesOf(std::string_view text) {
    return std::vector<std::uint8_t>(text.begin(), text.end());
}

const std::vector<std::uint8_t>& secret() {
    static const std::vector<std::uint8_t> s = bytesOf("0123456789abcdef");
    return s;
}

std::string hex(std::span<const std::uint8_t> bytes) {
    static constexpr char kDigits[] = "0123456789abcdef";
    std::string out;
    for (const std::uint8_t b : bytes) {
        out.push_back(kDigits[b >> 4]);
        out.push_back(kDigits[b & 0x0f]);
    }
    return out;
}

// Signs arbitrary text as the server would, so the field rules behind the signature check can be
// reached with malformed fields.
std::string signBody(std::string_view body, std::span<const std::uint8_t> key = secret()) {
    return std::string(body) + "." + hex(hmacSha256(key, body));
}

// Verifies and expects a refusal with `code` whose message contains `says`.
void expectRefused(
    std::string_view token, ErrorCode code, std::string_view says, std::int64_t now = kNow) {
    const auto r = verifyToken(token, secret(), now);
    ASSERT_FALSE(r.ok()) << "accepted: " << token;
    EXPECT_EQ(r.error().code, code) << token << ": " << r.error().message;
    EXPECT_NE(r.error().message.find(says), std::string::npos)
        << token << ": \"" << r.error().message << "\" does not say \"" << says << "\"";
}

// --- HMAC itself ------------------------------------------------------------------------------

TEST(HmacSha256, matchesRfc4231TestCase2) {
    const auto mac = hmacSha256(bytesOf("Jefe"), "what do ya want for nothing?");
    EXPECT_EQ(hex(mac), "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
}

TEST(HmacSha256, matchesRfc4231TestCases1And6) {
    const std::vector<std::uint8_t> key1(20, 0x0b);
    EXPECT_EQ(
        hex(hmacSha256(key1, "Hi There")),
        "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
    // a key longer than the SHA-256 block is hashed first
    const std::vector<std::uint8_t> key6(131, 0xaa);
    EXPECT_EQ(
        hex(hmacSha256(key6, "Test Using Larger Than Block-Size Key - Hash Key First")),
        "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
}

TEST(HmacSha256, acceptsEmptyKeyAndMessage) {
    // an empty key is zero-padded to the block size, exactly like a single zero byte
    const std::vector<std::uint8_t> zero(1, 0);
    EXPECT_EQ(hmacSha256({}, ""), hmacSha256(zero, ""));
    EXPECT_NE(hmacSha256({}, ""), hmacSha256({}, "x"));
}

// --- roles ------------------------------------------------------------------------------------

TEST(Role, namesRoundTripAndUnknownNamesAreRefused) {
    for (const Role r : {Role::kViewer, Role::kDeformer, Role::kAdmin}) {
        const auto parsed = parseRole(toString(r));
        ASSERT_TRUE(parsed.ok()) << r;
        EXPECT_EQ(*parsed, r);
    }
    EXPECT_STREQ(toString(Role::kViewer), "viewer");
    EXPECT_STREQ(toString(Role::kDeformer), "deformer");
    EXPECT_STREQ(toString(Role::kAdmin), "admin");
    for (const char* bad : {"", "Admin", "ADMIN", "admin ", "root", "unknown", "view"}) {
        const auto parsed = parseRole(bad);
        ASSERT_FALSE(parsed.ok()) << bad;
        EXPECT_EQ(parsed.error().code, ErrorCode::kBadFormat);
    }
}

TEST(Role, permissionsGrowWithTheRoleAndFailClosedOutsideTheEnum) {
    EXPECT_FALSE(mayDeform(Role::kViewer));
    EXPECT_FALSE(mayAdminister(Role::kViewer));
    EXPECT_TRUE(mayDeform(Role::kDeformer));
    EXPECT_FALSE(mayAdminister(Role::kDeformer));
    EXPECT_TRUE(mayDeform(Role::kAdmin));
    EXPECT_TRUE(mayAdminister(Role::kAdmin));
    for (const auto raw : {0, 4, 255}) {
        const auto r = static_cast<Role>(raw);
        EXPECT_FALSE(mayDeform(r)) << raw;
        EXPECT_FALSE(mayAdminister(r)) << raw;
        EXPECT_STREQ(toString(r), "unknown");
    }
}

// --- mint and verify --------------------------------------------------------------------------

TEST(AuthToken, mintMatchesAGoldenToken) {
    // mac from: printf 'v1.42.deformer.1700000000' | openssl dgst -sha256 -hmac 0123456789abcdef
    const TokenClaims claims{42, Role::kDeformer, 1'700'000'000};
    EXPECT_EQ(
        mintToken(claims, secret()),
        "v1.42.deformer.1700000000."
        "dc96613f106291ae4a0d8e2aef34d293297450bca2063d327a693e814b4ed1d9");
}

TEST(AuthToken, roundTripsForEachRoleAndTheExtremeValues) {
    const TokenClaims cases[] = {
        {7, Role::kViewer, kLater},
        {7, Role::kDeformer, kLater},
        {7, Role::kAdmin, kLater},
        {0, Role::kViewer, kLater},
        {std::numeric_limits<std::uint64_t>::max(), Role::kDeformer,
         std::numeric_limits<std::int64_t>::max()},
    };
    for (const TokenClaims& claims : cases) {
        const std::string token = mintToken(claims, secret());
        EXPECT_LE(token.size(), kMaxTokenLength);
        const auto r = verifyToken(token, secret(), kNow);
        ASSERT_TRUE(r.ok()) << token << ": " << r.error().message;
        EXPECT_EQ(*r, claims);
    }
}

TEST(AuthToken, longestPossibleTokenFitsTheLimit) {
    const TokenClaims claims{
        std::numeric_limits<std::uint64_t>::max(), Role::kDeformer,
        std::numeric_limits<std::int64_t>::max()};
    EXPECT_EQ(mintToken(claims, secret()).size(), 117u);
}

TEST(AuthToken, wrongSecretIsRefused) {
    const std::string token = mintToken({7, Role::kAdmin, kLater}, secret());
    const auto other = bytesOf("0123456789abcdeF");
    const auto r = verifyToken(token, other, kNow);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kHashMismatch);
}

TEST(AuthToken, editedFieldsBreakTheSignature) {
    const std::string token = mintToken({7, Role::kDeformer, kLater}, secret());
    const std::string mac = token.substr(token.rfind('.'));
    const std::string later = std::to_string(kLater);
    expectRefused("v1.8.deformer." + later + mac, ErrorCode::kHashMismatch, "signature");
    expectRefused("v1.7.admin." + later + mac, ErrorCode::kHashMismatch, "signature");
    expectRefused(
        "v1.7.deformer." + std::to_string(kLater + 1) + mac, ErrorCode::kHashMismatch, "signature");
    // even a field that would not parse is caught by the signature first
    expectRefused("v1.007.deformer." + later + mac, ErrorCode::kHashMismatch, "signature");
}

TEST(AuthToken, everySignatureCharacterMatters) {
    const std::string token = mintToken({7, Role::kViewer, kLater}, secret());
    const std::size_t mac_start = token.rfind('.') + 1;
    ASSERT_EQ(token.size() - mac_start, 64u);
    for (std::size_t i = mac_start; i < token.size(); ++i) {
        std::string edited = token;
        edited[i] = edited[i] == '0' ? '1' : '0';
        expectRefused(edited, ErrorCode::kHashMismatch, "signature");
    }
}

TEST(AuthToken, everyTruncationIsRefused) {
    const std::string token = mintToken({7, Role::kViewer, kLater}, secret());
    for (std::size_t n = 0; n < token.size(); ++n) {
        const auto r = verifyToken(std::string_view(token).substr(0, n), secret(), kNow);
        EXPECT_FALSE(r.ok()) << n;
    }
    expectRefused(token.substr(0, token.size() - 1), ErrorCode::kBadFormat, "64 lowercase hex");
}

TEST(AuthToken, malformedTokensAreRefusedWithTheRule) {
    const std::string token = mintToken({7, Role::kViewer, kLater}, secret());
    std::string upper = token;
    for (std::size_t i = token.rfind('.') + 1; i < upper.size(); ++i) {
        if (upper[i] >= 'a' && upper[i] <= 'f')
            upper[i] = static_cast<char>(upper[i] - 'a' + 'A');
    }
    ASSERT_NE(upper, token); // this mac has letters a-f, so the edit changes something

    expectRefused("", ErrorCode::kBadFormat, "empty");
    expectRefused(std::string(10'000, 'a'), ErrorCode::kOutOfRange, "longer");
    expectRefused(token + std::string(kMaxTokenLength, '0'), ErrorCode::kOutOfRange, "longer");
    expectRefused(token + ".", ErrorCode::kBadFormat, "5 fields");
    expectRefused(token + ".x", ErrorCode::kBadFormat, "5 fields");
    expectRefused("v1.." + token.substr(3), ErrorCode::kBadFormat, "5 fields");
    expectRefused("v1.7.." + token.substr(5), ErrorCode::kBadFormat, "5 fields");
    expectRefused(token.substr(0, token.rfind('.')), ErrorCode::kBadFormat, "5 fields");
    expectRefused("v1", ErrorCode::kBadFormat, "5 fields");
    expectRefused(upper, ErrorCode::kBadFormat, "lowercase hex");
    expectRefused(token + "0", ErrorCode::kBadFormat, "64 lowercase hex");
    expectRefused(token.substr(0, token.size() - 1) + "g", ErrorCode::kBadFormat, "lowercase hex");
    expectRefused("V1" + token.substr(2), ErrorCode::kBadFormat, "version");
    expectRefused("1" + token.substr(2), ErrorCode::kBadFormat, "version");
    expectRefused(" " + token, ErrorCode::kBadFormat, "version");
    expectRefused("v2" + token.substr(2), ErrorCode::kUnsupported, "v2");
    expectRefused("v10" + token.substr(2), ErrorCode::kUnsupported, "v10");
    expectRefused(std::string("v1\0", 3) + token.substr(2), ErrorCode::kBadFormat, "version");
}

TEST(AuthToken, signedButMalformedFieldsAreStillRefused) {
    // these bodies carry a valid signature, so only the field rules can refuse them: a minting
    // bug elsewhere must not turn into odd claims
    const std::string later = std::to_string(kLater);
    struct Case {
        std::string body;
        ErrorCode code;
        const char* says;
    };
    const Case cases[] = {
        {"v1..viewer." + later, ErrorCode::kBadFormat, "player id is empty"},
        {"v1.007.viewer." + later, ErrorCode::kBadFormat, "player id has a leading zero"},
        {"v1.00.viewer." + later, ErrorCode::kBadFormat, "player id has a leading zero"},
        {"v1.+7.viewer." + later, ErrorCode::kBadFormat, "player id must be plain decimal"},
        {"v1.-7.viewer." + later, ErrorCode::kBadFormat, "player id must be plain decimal"},
        {"v1. 7.viewer." + later, ErrorCode::kBadFormat, "player id must be plain decimal"},
        {"v1.7a.viewer." + later, ErrorCode::kBadFormat, "player id must be plain decimal"},
        {"v1.0x7.viewer." + later, ErrorCode::kBadFormat, "player id must be plain decimal"},
        {"v1.18446744073709551616.viewer." + later, ErrorCode::kOutOfRange, "player id exceeds"},
        {"v1.99999999999999999999.viewer." + later, ErrorCode::kOutOfRange, "player id exceeds"},
        {"v1.7..", ErrorCode::kBadFormat, "unknown role"},
        {"v1.7.Admin." + later, ErrorCode::kBadFormat, "unknown role"},
        {"v1.7.root." + later, ErrorCode::kBadFormat, "unknown role"},
        {"v1.7.admin.", ErrorCode::kBadFormat, "expiry is empty"},
        {"v1.7.admin.-1", ErrorCode::kBadFormat, "expiry must be plain decimal"},
        {"v1.7.admin.+" + later, ErrorCode::kBadFormat, "expiry must be plain decimal"},
        {"v1.7.admin.0" + later, ErrorCode::kBadFormat, "expiry has a leading zero"},
        {"v1.7.admin.1e10", ErrorCode::kBadFormat, "expiry must be plain decimal"},
        {"v1.7.admin.9223372036854775808", ErrorCode::kOutOfRange, "expiry exceeds"},
        {"v1.7.admin.18446744073709551616", ErrorCode::kOutOfRange, "expiry exceeds"},
    };
    for (const Case& c : cases)
        expectRefused(signBody(c.body), c.code, c.says);

    // the same helper does produce accepted tokens, so the refusals above are the field rules
    const auto ok = verifyToken(signBody("v1.18446744073709551615.admin." + later), secret(), kNow);
    ASSERT_TRUE(ok.ok()) << ok.error().message;
    EXPECT_EQ(ok->player_id, std::numeric_limits<std::uint64_t>::max());
}

TEST(AuthToken, expiresExactlyAtItsExpiryTime) {
    const std::string token = mintToken({7, Role::kAdmin, kLater}, secret());
    EXPECT_TRUE(verifyToken(token, secret(), kLater - 1).ok());
    expectRefused(token, ErrorCode::kOutOfRange, "token expired", kLater);
    expectRefused(token, ErrorCode::kOutOfRange, "token expired", kLater + 1);
    expectRefused(
        token, ErrorCode::kOutOfRange, "token expired", std::numeric_limits<std::int64_t>::max());
    EXPECT_TRUE(verifyToken(token, secret(), std::numeric_limits<std::int64_t>::min()).ok());
}

TEST(AuthToken, shortSecretNeverVerifies) {
    const auto short_key = bytesOf("fifteen bytes!!");
    ASSERT_EQ(short_key.size(), kMinSecretBytes - 1);
    const std::string token = signBody("v1.7.admin." + std::to_string(kLater), short_key);
    const auto r = verifyToken(token, short_key, kNow);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kOutOfRange);
    EXPECT_FALSE(verifyToken(token, {}, kNow).ok());
}

// --- secrets ----------------------------------------------------------------------------------

TEST(ParseSecret, acceptsTextAndHex) {
    const auto text = parseSecret("correct horse battery staple");
    ASSERT_TRUE(text.ok()) << text.error().message;
    EXPECT_EQ(*text, bytesOf("correct horse battery staple"));

    const auto hex_lower = parseSecret("hex:000102030405060708090a0b0c0d0e0f");
    ASSERT_TRUE(hex_lower.ok()) << hex_lower.error().message;
    std::vector<std::uint8_t> expected(16);
    for (std::size_t i = 0; i < expected.size(); ++i)
        expected[i] = static_cast<std::uint8_t>(i);
    EXPECT_EQ(*hex_lower, expected);

    const auto hex_upper = parseSecret("hex:000102030405060708090A0B0C0D0E0F");
    ASSERT_TRUE(hex_upper.ok()) << hex_upper.error().message;
    EXPECT_EQ(*hex_upper, expected);

    const auto inner_space = parseSecret("a secret with spaces");
    EXPECT_TRUE(inner_space.ok());
    const auto longest = parseSecret(std::string(kMaxSecretBytes, 'k'));
    EXPECT_TRUE(longest.ok());
}

TEST(ParseSecret, refusesEachBadSecretWithTheRule) {
    struct Case {
        std::string text;
        ErrorCode code;
        const char* says;
    };
    const Case cases[] = {
        {"", ErrorCode::kOutOfRange, "shorter than 16"},
        {"fifteen bytes!!", ErrorCode::kOutOfRange, "shorter than 16"},
        {"hex:", ErrorCode::kOutOfRange, "shorter than 16"},
        {"hex:000102030405060708090a0b0c0d0e", ErrorCode::kOutOfRange, "shorter than 16"},
        {"hex:000102030405060708090a0b0c0d0e0", ErrorCode::kBadFormat, "odd number"},
        {"hex:000102030405060708090a0b0c0d0e0g", ErrorCode::kBadFormat, "not hex"},
        {"hex:0x0102030405060708090a0b0c0d0e0f", ErrorCode::kBadFormat, "not hex"},
        {"hex: 00102030405060708090a0b0c0d0e0f", ErrorCode::kBadFormat, "not hex"},
        {"hex:" + std::string(2 * kMaxSecretBytes + 2, 'a'), ErrorCode::kOutOfRange, "longer"},
        {std::string(kMaxSecretBytes + 1, 'k'), ErrorCode::kOutOfRange, "longer"},
        {"a long enough secret\n", ErrorCode::kBadFormat, "whitespace"},
        {" a long enough secret", ErrorCode::kBadFormat, "whitespace"},
        {"a long enough secret\r\n", ErrorCode::kBadFormat, "whitespace"},
    };
    for (const Case& c : cases) {
        const auto r = parseSecret(c.text);
        ASSERT_FALSE(r.ok()) << c.text;
        EXPECT_EQ(r.error().code, c.code) << c.text << ": " << r.error().message;
        EXPECT_NE(r.error().message.find(c.says), std::string::npos)
            << c.text << ": " << r.error().message;
    }
}

TEST(ParseSecret, parsedSecretSignsTokensTheOtherSideAccepts) {
    const auto a = parseSecret("hex:30313233343536373839616263646566"); // "0123456789abcdef"
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(*a, secret());
    const std::string token = mintToken({3, Role::kViewer, kLater}, *a);
    EXPECT_TRUE(verifyToken(token, secret(), kNow).ok());
}

} // namespace
} // namespace terrain::server
