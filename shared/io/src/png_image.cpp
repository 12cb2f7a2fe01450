#include <terrain/io/png_image.h>

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <memory>

namespace terrain::io {
namespace {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

} // namespace

Result<GrayImage> readGrayPng(const std::filesystem::path& path) {
    std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
    if (!file)
        return makeError(ErrorCode::kIo, "cannot open " + path.string());
    png_byte header[8] = {};
    if (std::fread(header, 1, 8, file.get()) != 8 || png_sig_cmp(header, 0, 8) != 0)
        return makeError(ErrorCode::kBadFormat, path.string() + " is not a PNG file");

    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (png == nullptr || info == nullptr) {
        png_destroy_read_struct(&png, nullptr, nullptr);
        return makeError(ErrorCode::kIo, "libpng could not allocate its state");
    }
    GrayImage image;
    std::vector<png_bytep> rows;
    std::vector<std::uint8_t> buffer;
    // libpng reports corrupt data by longjmp; nothing with a destructor is created below it
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        return makeError(ErrorCode::kBadFormat, path.string() + " is a corrupt PNG");
    }
    png_init_io(png, file.get());
    png_set_sig_bytes(png, 8);
    png_read_info(png, info);
    const png_uint_32 width = png_get_image_width(png, info);
    const png_uint_32 height = png_get_image_height(png, info);
    const int color = png_get_color_type(png, info);
    const int depth = png_get_bit_depth(png, info);
    if (color != PNG_COLOR_TYPE_GRAY || (depth != 8 && depth != 16)) {
        png_destroy_read_struct(&png, &info, nullptr);
        return makeError(
            ErrorCode::kUnsupported,
            path.string() + ": only 8- or 16-bit grayscale PNG holds heights");
    }
    if (width > 32768 || height > 32768) {
        png_destroy_read_struct(&png, &info, nullptr);
        return makeError(ErrorCode::kOutOfRange, path.string() + " is larger than 32768 per side");
    }
    png_read_update_info(png, info);
    const std::size_t stride = png_get_rowbytes(png, info);
    buffer.resize(stride * height);
    rows.resize(height);
    for (png_uint_32 y = 0; y < height; ++y)
        rows[y] = buffer.data() + y * stride;
    png_read_image(png, rows.data());
    png_read_end(png, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);

    image.width = static_cast<std::int32_t>(width);
    image.height = static_cast<std::int32_t>(height);
    image.bit_depth = depth;
    image.pixels.resize(static_cast<std::size_t>(width) * height);
    for (std::size_t i = 0; i < image.pixels.size(); ++i)
        image.pixels[i] = depth == 16
                              ? static_cast<std::uint16_t>((buffer[2 * i] << 8) | buffer[2 * i + 1])
                              : buffer[i]; // PNG stores 16-bit samples big-endian
    return image;
}

Status writeRgbPng(const std::filesystem::path& path, const RgbImage& image) {
    png_image out{};
    out.version = PNG_IMAGE_VERSION;
    out.width = static_cast<png_uint_32>(image.width);
    out.height = static_cast<png_uint_32>(image.height);
    out.format = PNG_FORMAT_RGB;
    if (png_image_write_to_file(&out, path.c_str(), 0, image.rgb.data(), 0, nullptr) == 0)
        return makeError(ErrorCode::kIo, "cannot write " + path.string() + ": " + out.message);
    return Ok{};
}

} // namespace terrain::io
