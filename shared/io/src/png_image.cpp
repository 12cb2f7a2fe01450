#include <terrain/io/png_image.h>

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <memory>
#include <new>

namespace terrain::io {
namespace {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};

// What the libpng part reports back; owned by the caller, outside the setjmp frame.
struct PngRead {
    GrayImage* image = nullptr;
    std::uint64_t max_pixels = 0;
    const char* failure = nullptr; // set on refusal; the message names the rule
    ErrorCode code = ErrorCode::kBadFormat;
    std::vector<std::uint8_t>* row = nullptr;
};

// All libpng calls live here. libpng reports corrupt data by longjmp to the setjmp below, so this
// function keeps only trivial locals that are not modified after setjmp; the storage it fills
// (image pixels, row buffer) belongs to the caller, whose frame longjmp never skips.
bool decodeGray(std::FILE* file, PngRead* out) {
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    if (png == nullptr) {
        out->failure = "libpng could not allocate its state";
        out->code = ErrorCode::kIo;
        return false;
    }
    png_infop info = png_create_info_struct(png);
    if (info == nullptr || setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        if (out->failure == nullptr)
            out->failure = "corrupt or truncated PNG data";
        return false;
    }
    png_init_io(png, file);
    png_set_sig_bytes(png, 8);
    png_set_user_limits(png, 32768, 32768);
    png_read_info(png, info);
    const png_uint_32 width = png_get_image_width(png, info);
    const png_uint_32 height = png_get_image_height(png, info);
    const int color = png_get_color_type(png, info);
    const int depth = png_get_bit_depth(png, info);
    if (color != PNG_COLOR_TYPE_GRAY || (depth != 8 && depth != 16)) {
        out->failure = "only 8- or 16-bit grayscale PNG holds heights";
        out->code = ErrorCode::kUnsupported;
        png_destroy_read_struct(&png, &info, nullptr);
        return false;
    }
    if (static_cast<std::uint64_t>(width) * height > out->max_pixels) {
        out->failure = "image has more pixels than the import budget allows";
        out->code = ErrorCode::kOutOfRange;
        png_destroy_read_struct(&png, &info, nullptr);
        return false;
    }
    if (png_get_interlace_type(png, info) != PNG_INTERLACE_NONE) {
        out->failure = "interlaced PNG is not supported for height maps";
        out->code = ErrorCode::kUnsupported;
        png_destroy_read_struct(&png, &info, nullptr);
        return false;
    }
    out->image->width = static_cast<std::int32_t>(width);
    out->image->height = static_cast<std::int32_t>(height);
    out->image->bit_depth = depth;
    out->row->resize(png_get_rowbytes(png, info));
    for (png_uint_32 y = 0; y < height; ++y) {
        // rows are appended as they arrive: a truncated file fails before a large allocation
        png_read_row(png, out->row->data(), nullptr);
        const std::uint8_t* r = out->row->data();
        for (png_uint_32 x = 0; x < width; ++x)
            out->image->pixels.push_back(
                depth == 16 ? static_cast<std::uint16_t>((r[2 * x] << 8) | r[2 * x + 1]) : r[x]);
    }
    png_read_end(png, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);
    return true;
}

} // namespace

Result<GrayImage> readGrayPng(const std::filesystem::path& path, std::uint64_t max_pixels) {
    std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
    if (!file)
        return makeError(ErrorCode::kIo, "cannot open " + path.string());
    png_byte header[8] = {};
    if (std::fread(header, 1, 8, file.get()) != 8 || png_sig_cmp(header, 0, 8) != 0)
        return makeError(ErrorCode::kBadFormat, path.string() + " is not a PNG file");
    GrayImage image;
    std::vector<std::uint8_t> row;
    PngRead read;
    read.image = &image;
    read.max_pixels = max_pixels;
    read.row = &row;
    try {
        if (!decodeGray(file.get(), &read))
            return makeError(read.code, path.string() + ": " + read.failure);
    } catch (const std::bad_alloc&) {
        return makeError(
            ErrorCode::kOutOfRange, path.string() + ": not enough memory for the image");
    }
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
