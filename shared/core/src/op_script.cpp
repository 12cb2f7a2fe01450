#include <terrain/op_script.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>

namespace terrain {
namespace {

std::vector<std::string_view> splitFields(std::string_view line) {
    std::vector<std::string_view> out;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r'))
            ++i;
        const std::size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r')
            ++i;
        if (i > start)
            out.push_back(line.substr(start, i - start));
    }
    return out;
}

// The fields of the next line of `text` that has any (a '#' starts a comment), consumed from
// `text`; `line_no` counts every line passed. False at the end.
bool nextFields(std::string_view& text, int& line_no, std::vector<std::string_view>& fields) {
    while (!text.empty()) {
        const std::size_t eol = text.find('\n');
        std::string_view line = text.substr(0, eol);
        text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 1);
        ++line_no;
        if (const std::size_t hash = line.find('#'); hash != std::string_view::npos)
            line = line.substr(0, hash);
        fields = splitFields(line);
        if (!fields.empty())
            return true;
    }
    return false;
}

bool parseNumber(std::string_view s, double& out) {
    const char* end = s.data() + s.size();
    const auto [ptr, ec] = std::from_chars(s.data(), end, out);
    return ec == std::errc() && ptr == end;
}

// SplitMix64: small, well-mixed, integer-only
struct Rng {
    std::uint64_t state;
    std::uint64_t next() {
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    // uniform in [0, 1) with 53 bits; exact conversion, so identical on every platform
    double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

} // namespace

Result<std::vector<OpRequest>> parseOpScript(std::string_view text) {
    std::vector<OpRequest> ops;
    int line_no = 0;
    std::vector<std::string_view> f;
    while (nextFields(text, line_no, f)) {
        auto fail = [&](std::initializer_list<std::string_view> rule) {
            // note: built by append; GCC 12 -O3 warns falsely (-Wrestrict) on chained operator+
            std::string message = "op script line ";
            message.append(std::to_string(line_no)).append(": ");
            for (std::string_view part : rule)
                message.append(part);
            return makeError(ErrorCode::kBadFormat, std::move(message));
        };
        OpRequest r;
        std::size_t min_fields = 5;
        std::size_t max_fields = 5;
        if (f[0] == "crater") {
            r.kind = OpKind::kCrater;
            r.strength = 0.25;
            max_fields = 6;
        } else if (f[0] == "raise") {
            r.kind = OpKind::kRaise;
        } else if (f[0] == "flatten") {
            r.kind = OpKind::kFlatten;
            max_fields = 6;
        } else if (f[0] == "smooth") {
            r.kind = OpKind::kSmooth;
            min_fields = 4;
        } else {
            return fail({"unknown op '", f[0], "' (crater, raise, flatten, smooth)"});
        }
        if (f.size() < min_fields || f.size() > max_fields)
            return fail(
                {f[0], " takes ", std::to_string(min_fields - 1), "..",
                 std::to_string(max_fields - 1), " numbers, got ", std::to_string(f.size() - 1)});
        double v[5] = {};
        for (std::size_t i = 1; i < f.size(); ++i)
            if (!parseNumber(f[i], v[i - 1]))
                return fail({"'", f[i], "' is not a number"});
        r.x = v[0];
        r.y = v[1];
        r.radius = v[2];
        if (r.kind == OpKind::kSmooth) {
            r.height = 0.0;
            r.strength = f.size() > 4 ? v[3] : 1.0;
        } else {
            r.height = v[3];
            if (f.size() > 5)
                r.strength = v[4];
        }
        ops.push_back(r);
    }
    return ops;
}

Result<std::vector<DeformOp>> parseCanonicalOps(std::string_view text) {
    std::vector<DeformOp> ops;
    int line_no = 0;
    std::vector<std::string_view> f;
    while (nextFields(text, line_no, f)) {
        auto fail = [&](std::string_view rule) {
            std::string message = "canonical op script line ";
            message.append(std::to_string(line_no)).append(": ").append(rule);
            return makeError(ErrorCode::kBadFormat, std::move(message));
        };
        DeformOp op;
        if (f[0] == "crater")
            op.kind = OpKind::kCrater;
        else if (f[0] == "raise")
            op.kind = OpKind::kRaise;
        else if (f[0] == "flatten")
            op.kind = OpKind::kFlatten;
        else if (f[0] == "smooth")
            op.kind = OpKind::kSmooth;
        else
            return fail("the kind must be crater, raise, flatten or smooth");
        if (f.size() != 6)
            return fail("an op is a kind and five integers");
        std::int64_t v[5] = {};
        for (std::size_t i = 1; i < 6; ++i) {
            const char* end = f[i].data() + f[i].size();
            const auto [ptr, ec] = std::from_chars(f[i].data(), end, v[i - 1]);
            if (ec != std::errc() || ptr != end)
                return fail("every field after the kind must be an integer");
        }
        if (v[2] < INT32_MIN || v[2] > INT32_MAX || v[3] < INT32_MIN || v[3] > INT32_MAX ||
            v[4] < INT32_MIN || v[4] > INT32_MAX)
            return fail("radius, height and strength must fit in 32 bits");
        op.center_x = v[0];
        op.center_y = v[1];
        op.radius = static_cast<std::int32_t>(v[2]);
        op.height = static_cast<std::int32_t>(v[3]);
        op.strength = static_cast<std::int32_t>(v[4]);
        ops.push_back(op);
    }
    return ops;
}

std::string formatCanonicalOp(const DeformOp& op) {
    std::string s = toString(op.kind);
    for (std::int64_t v :
         {op.center_x, op.center_y, std::int64_t{op.radius}, std::int64_t{op.height},
          std::int64_t{op.strength}})
        s.append(" ").append(std::to_string(v));
    return s;
}

std::vector<OpRequest> randomCraters(const WorldSpec& spec, const CraterSeries& s) {
    Rng rng{s.seed};
    std::vector<OpRequest> ops;
    ops.reserve(static_cast<std::size_t>(std::max(0, s.count)));
    const double w = spec.extentX() - 2.0 * s.margin;
    const double h = spec.extentY() - 2.0 * s.margin;
    for (int i = 0; i < s.count; ++i) {
        OpRequest r;
        r.kind = OpKind::kCrater;
        r.x = s.margin + rng.unit() * w;
        r.y = s.margin + rng.unit() * h;
        r.radius = s.min_radius + rng.unit() * (s.max_radius - s.min_radius);
        r.height = s.depth_ratio * r.radius;
        r.strength = s.rim_ratio;
        ops.push_back(r);
    }
    return ops;
}

} // namespace terrain
