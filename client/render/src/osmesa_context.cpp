#include <terrain/render/osmesa_context.h>

#include <dlfcn.h>

#include <cstring>
#include <mutex>
#include <string>

namespace terrain::render {

namespace {
// From GL/osmesa.h, declared here because that header pulls in the GL 1.x prototypes.
constexpr int kOsmesaDepthBits = 0x30;
constexpr int kOsmesaStencilBits = 0x31;
constexpr int kOsmesaAccumBits = 0x32;
constexpr int kOsmesaProfile = 0x33;
constexpr int kOsmesaCoreProfile = 0x34;
constexpr int kOsmesaFormat = 0x22;
constexpr int kOsmesaMajorVersion = 0x36;
constexpr int kOsmesaMinorVersion = 0x37;

using CreateContextAttribsFn = void* (*)(const int* attributes, void* share);
using DestroyContextFn = void (*)(void* context);
using MakeCurrentFn = unsigned char (*)(void* context, void* buffer, GLenum type, int w, int h);
using GetProcAddressFn = void* (*)(const char* name);

template <typename F> F symbol(void* library, const char* name) {
    void* p = dlsym(library, name);
    F f = nullptr;
    static_assert(sizeof(f) == sizeof(p));
    std::memcpy(&f, &p, sizeof(p));
    return f;
}
} // namespace

struct OsmesaContext::Library {
    void* handle = nullptr;
    CreateContextAttribsFn create = nullptr;
    DestroyContextFn destroy = nullptr;
    MakeCurrentFn make_current = nullptr;
    GetProcAddressFn get_proc = nullptr;
    // never dlclose'd: llvmpipe's threads and exit handlers outlive the last context
};

Result<std::unique_ptr<OsmesaContext>>
OsmesaContext::create(int width, int height, const ContextOptions& options) {
    if (width < 1 || height < 1 || width > 8192 || height > 8192)
        return makeError(
            ErrorCode::kOutOfRange, "offscreen size " + std::to_string(width) + " x " +
                                        std::to_string(height) +
                                        " must be within 1..8192 per side");
    // one library handle for the process
    static std::mutex mutex;
    static std::weak_ptr<Library> shared;
    std::shared_ptr<Library> lib;
    {
        const std::lock_guard<std::mutex> lock(mutex);
        lib = shared.lock();
        if (!lib) {
            lib = std::make_shared<Library>();
            lib->handle = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL);
            if (lib->handle == nullptr)
                return makeError(
                    ErrorCode::kUnsupported,
                    std::string("cannot open libOSMesa.so.8 (Debian: libosmesa6): ") + dlerror());
            lib->create = symbol<CreateContextAttribsFn>(lib->handle, "OSMesaCreateContextAttribs");
            lib->destroy = symbol<DestroyContextFn>(lib->handle, "OSMesaDestroyContext");
            lib->make_current = symbol<MakeCurrentFn>(lib->handle, "OSMesaMakeCurrent");
            lib->get_proc = symbol<GetProcAddressFn>(lib->handle, "OSMesaGetProcAddress");
            if (!lib->create || !lib->destroy || !lib->make_current || !lib->get_proc)
                return makeError(
                    ErrorCode::kUnsupported, "libOSMesa.so.8 lacks the OSMesa 11 entry points");
            shared = lib;
        }
    }
    const int attributes[] = {
        kOsmesaFormat,
        GL_RGBA,
        kOsmesaDepthBits,
        24,
        kOsmesaStencilBits,
        0,
        kOsmesaAccumBits,
        0,
        kOsmesaProfile,
        kOsmesaCoreProfile,
        kOsmesaMajorVersion,
        3,
        kOsmesaMinorVersion,
        3,
        0};
    void* context = lib->create(attributes, nullptr);
    if (context == nullptr)
        return makeError(ErrorCode::kUnsupported, "OSMesa gives no OpenGL 3.3 core context");

    std::unique_ptr<OsmesaContext> c(new OsmesaContext());
    c->library_ = std::move(lib);
    c->context_ = context;
    c->width_ = width;
    c->height_ = height;
    c->buffer_.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 4);
    if (!c->bindToThread())
        return makeError(ErrorCode::kUnsupported, "OSMesaMakeCurrent failed");
    c->makeCurrent();
    Status loaded = c->gl_.load(
        [](const char* name, void* user) { return static_cast<Library*>(user)->get_proc(name); },
        c->library_.get());
    if (!loaded)
        return loaded.error();
    // OSMesa has no debug-context attribute; Mesa sends KHR_debug output once it is enabled
    c->attachDebugLog(options);
    return c;
}

bool OsmesaContext::bindToThread() const {
    return library_->make_current(context_, buffer_.data(), GL_UNSIGNED_BYTE, width_, height_) != 0;
}

io::RgbImage OsmesaContext::readPixels() const {
    makeCurrent();
    gl_.Finish();
    io::RgbImage image;
    image.width = width_;
    image.height = height_;
    image.rgb.resize(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) * 3);
    // RGBA rows, bottom row first (OSMesa's default, like GL)
    const auto w = static_cast<std::size_t>(width_);
    for (int y = 0; y < height_; ++y) {
        const unsigned char* in =
            buffer_.data() + static_cast<std::size_t>(height_ - 1 - y) * w * 4;
        std::uint8_t* out = image.rgb.data() + static_cast<std::size_t>(y) * w * 3;
        for (std::size_t x = 0; x < w; ++x, in += 4, out += 3) {
            out[0] = in[0];
            out[1] = in[1];
            out[2] = in[2];
        }
    }
    return image;
}

OsmesaContext::~OsmesaContext() {
    forgetCurrent();
    if (context_ != nullptr) {
        if (bindToThread())
            pacer_.release(gl_);
        library_->destroy(context_);
    }
}

} // namespace terrain::render
