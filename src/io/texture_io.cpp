// Texture decoding through OpenImageIO (see src/io/texture_io.h for the contract).
#include "io/texture_io.h"
#include "io/oiio_lib.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

extern "C" {
#include "core/input_file.h"
}

using namespace OIIO;

namespace {

// Formats a reason into why (never overflows, always terminated).
void say(char *why, size_t why_size, const std::string &text)
{
    if (why && why_size) snprintf(why, why_size, "%s", text.c_str());
}

// First line of OpenImageIO's pending error (clears it, so OIIO does not print it
// at exit), or fallback when there is none.
std::string oiio_reason(ImageInput *in, const char *fallback)
{
    std::string msg = in ? in->geterror() : std::string();
    std::string global = OIIO::geterror();
    if (msg.empty()) msg = global;
    if (msg.empty()) msg = fallback;
    size_t nl = msg.find('\n');
    if (nl != std::string::npos) msg.resize(nl);
    return msg;
}

// The configuration every image is opened with: colours as stored, not
// multiplied by alpha (OpenImageIO associates alpha by default, but glTF 2.0's
// images are not premultiplied: "Images", and the alpha of baseColorTexture is
// coverage, not a factor already in the colour).
ImageSpec unassociated_alpha()
{
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    return config;
}

// Reads subimage 0 of an opened input into img; 0 or -1 with why.
int read_opened(ImageInput *in, TextureImage *img, char *why, size_t why_size)
{
    const ImageSpec &spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1 || spec.nchannels <= 0) {
        say(why, why_size, "not a 2D image");
        return -1;
    }
    if (spec.width > SPT_TEXTURE_MAX_SIDE || spec.height > SPT_TEXTURE_MAX_SIDE) {
        say(why, why_size,
            std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                " texels is larger than " + std::to_string(SPT_TEXTURE_MAX_SIDE) + " per side");
        return -1;
    }
    int channels = spec.nchannels < 4 ? spec.nchannels : 4;
    size_t n = (size_t)spec.width * (size_t)spec.height * (size_t)channels;
    if (n * sizeof(float) > SPT_TEXTURE_MAX_BYTES) {
        say(why, why_size, "image needs more than 1 GiB as floats");
        return -1;
    }
    float *texels = (float *)malloc(n * sizeof(float));
    if (!texels) {
        say(why, why_size, "out of memory");
        return -1;
    }
    if (!in->read_image(0, 0, 0, channels, TypeDesc::FLOAT, texels)) {
        say(why, why_size, oiio_reason(in, "cannot decode the image"));
        free(texels);
        return -1;
    }
    for (size_t i = 0; i < n; i++)
        if (!std::isfinite(texels[i])) texels[i] = 0.0f;
    img->width = spec.width;
    img->height = spec.height;
    img->channels = channels;
    img->texels = texels;
    return 0;
}

// Opens the image name with config and reads it into img; fail says what went
// wrong when it cannot be opened.
int open_and_read(const char *name, const ImageSpec &config, const char *fail,
                  TextureImage *img, char *why, size_t why_size)
{
    auto in = ImageInput::open(name, &config);
    if (!in) {
        say(why, why_size, oiio_reason(nullptr, fail));
        return -1;
    }
    int rc = read_opened(in.get(), img, why, why_size);
    in->close();
    return rc;
}

uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

// CRC-32 of the PNG specification (ISO 3309, reflected, polynomial 0xEDB88320).
uint32_t png_crc(const unsigned char *p, size_t n)
{
    static uint32_t table[256];
    static bool ready = false;
    if (!ready) {
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++) c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            table[i] = c;
        }
        ready = true;
    }
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; i++) c = table[(c ^ p[i]) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

// Checks a PNG's chunk structure (IHDR first, every chunk inside the data with a
// correct CRC, IDAT present, IEND reached) before libpng sees it: libpng reports
// such damage by longjmp out of OpenImageIO's reader, which leaks its state.
bool png_structure_ok(const unsigned char *b, size_t size, char *why, size_t why_size)
{
    size_t pos = 8;
    bool first = true, idat = false;
    while (pos + 12 <= size) {
        uint32_t len = be32(b + pos);
        if (len > size - pos - 12) break;
        const unsigned char *type = b + pos + 4;
        if (png_crc(type, (size_t)len + 4) != be32(b + pos + 8 + len)) {
            say(why, why_size, std::string("corrupt PNG: bad CRC in chunk ") +
                                   std::string((const char *)type, 4));
            return false;
        }
        if (first && (memcmp(type, "IHDR", 4) || len != 13)) break;
        first = false;
        if (!memcmp(type, "IDAT", 4)) idat = true;
        if (!memcmp(type, "IEND", 4)) {
            if (idat) return true;
            break;
        }
        pos += (size_t)len + 12;
    }
    say(why, why_size, "truncated or corrupt PNG");
    return false;
}

} // namespace

static int load_file(const char *path, TextureImage *img, char *why, size_t why_size);
static int load_memory(const void *data, size_t size, const char *mime_type, TextureImage *img,
                       char *why, size_t why_size);

// The entry points: no exception of the image library (or std::bad_alloc for a
// huge image) escapes; it becomes the reason of a failed load.
extern "C" int oiio_texture_load_file(const char *path, TextureImage *img, char *why,
                                    size_t why_size)
{
    memset(img, 0, sizeof *img);
    try {
        return load_file(path, img, why, why_size);
    } catch (const std::exception &ex) {
        texture_io_free(img);
        say(why, why_size, ex.what());
        return -1;
    }
}

extern "C" int oiio_texture_load_memory(const void *data, size_t size, const char *mime_type,
                                      TextureImage *img, char *why, size_t why_size)
{
    memset(img, 0, sizeof *img);
    try {
        return load_memory(data, size, mime_type, img, why, why_size);
    } catch (const std::exception &ex) {
        texture_io_free(img);
        say(why, why_size, ex.what());
        return -1;
    }
}

static int load_file(const char *path, TextureImage *img, char *why, size_t why_size)
{
    memset(img, 0, sizeof *img);
    SptError e = {};
    if (input_check(path, "image", &e)) {
        const char *reason = strstr(e.msg, ": ");
        say(why, why_size, reason ? reason + 2 : e.msg);
        return -1;
    }
    // PNG and JPEG go through memory (and the PNG check); other formats (EXR, HDR,
    // TIFF...) are opened by name so OpenImageIO picks the reader.
    FILE *f = fopen(path, "rb");
    if (!f) {
        say(why, why_size, strerror(errno));
        return -1;
    }
    unsigned char head[8] = {0};
    size_t got = fread(head, 1, sizeof head, f);
    bool png = got == 8 && !memcmp(head, "\x89PNG\r\n\x1a\n", 8);
    bool jpeg = got >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF;
    if (png || jpeg) {
        std::string bytes((const char *)head, got);
        char chunk[65536];
        size_t n;
        while ((n = fread(chunk, 1, sizeof chunk, f)) > 0) {
            bytes.append(chunk, n);
            if (bytes.size() > SPT_TEXTURE_MAX_BYTES) break;
        }
        fclose(f);
        return oiio_texture_load_memory(bytes.data(), bytes.size(), nullptr, img, why, why_size);
    }
    fclose(f);
    return open_and_read(path, unassociated_alpha(), "cannot open the image", img, why, why_size);
}

static int load_memory(const void *data, size_t size, const char *mime_type, TextureImage *img,
                       char *why, size_t why_size)
{
    memset(img, 0, sizeof *img);
    const unsigned char *b = (const unsigned char *)data;
    // OpenImageIO picks its reader from a file name: make one from the magic
    // bytes, or from the MIME type when the bytes are not recognised.
    const char *name = nullptr;
    if (size >= 8 && !memcmp(b, "\x89PNG\r\n\x1a\n", 8))
        name = "memory.png";
    else if (size >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF)
        name = "memory.jpg";
    else if (size >= 12 && !memcmp(b, "RIFF", 4) && !memcmp(b + 8, "WEBP", 4))
        name = "memory.webp"; // EXT_texture_webp
    else if (mime_type && !strcmp(mime_type, "image/png"))
        name = "memory.png";
    else if (mime_type && !strcmp(mime_type, "image/jpeg"))
        name = "memory.jpg";
    if (!name || size == 0) {
        say(why, why_size, "not a PNG, JPEG or WebP image");
        return -1;
    }
    if (!strcmp(name, "memory.png") && !png_structure_ok(b, size, why, why_size)) return -1;
    Filesystem::IOMemReader proxy(data, size);
    // The proxy goes in the configuration (with a configuration, OpenImageIO 2.4
    // ignores the proxy argument), next to unassociated_alpha's setting.
    ImageSpec config = unassociated_alpha();
    void *proxy_ptr = &proxy;
    config.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy_ptr);
    return open_and_read(name, config, "cannot decode the image", img, why, why_size);
}
