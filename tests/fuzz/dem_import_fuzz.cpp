// libFuzzer target: DEM sidecar JSON + raw samples (untrusted files).
// Property: never crash, never allocate beyond the sample budget; an import either succeeds with a
// terrain of the declared size or fails with an error.

#include <terrain/io/dem_import.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // the first zero byte splits the sidecar text from the raw samples
    const auto* zero = static_cast<const std::uint8_t*>(std::memchr(data, 0, size));
    const std::size_t split = zero != nullptr ? static_cast<std::size_t>(zero - data) : size;
    const std::string_view json(reinterpret_cast<const char*>(data), split);
    const std::span<const std::uint8_t> raw(
        data + std::min(size, split + 1), size - std::min(size, split + 1));
    terrain::io::DemImportOptions options;
    options.max_samples = 1 << 16;
    auto dem = terrain::io::importDemFromMemory(json, raw, options);
    if (dem &&
        static_cast<std::uint64_t>(dem->info.width) * static_cast<std::uint64_t>(dem->info.height) >
            options.max_samples)
        std::abort();
    return 0;
}
