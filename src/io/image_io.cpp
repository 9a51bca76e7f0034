// The only OpenImageIO code of spectrace (contracts in src/io/image_io.h). No C++
// exception or OIIO type crosses the C interface.
#include "io/image_io.h"
#include "io/oiio_lib.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

using namespace OIIO;

namespace {

// The most specific reason OIIO has: the object's own error, else the global one.
template <class T> std::string oiio_reason(const T *obj)
{
    std::string msg = obj ? obj->geterror() : std::string();
    if (msg.empty())
        msg = OIIO::geterror();
    if (msg.empty())
        msg = "unknown OpenImageIO error";
    // One error line: keep only the first line of OIIO's message.
    size_t nl = msg.find('\n');
    if (nl != std::string::npos)
        msg.resize(nl);
    return msg;
}

// Opens path for reading, or fills e and returns null.
std::unique_ptr<ImageInput> open_input(const char *path, SptError *e)
{
    auto in = ImageInput::open(path);
    if (!in)
        spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read image: %s", path,
                 oiio_reason<ImageInput>(nullptr).c_str());
    return in;
}

} // namespace

extern "C" int oiio_image_encode(const char *path, const void *pixels, int pixel_type,
                               int width, int height, int channels,
                               const ImageIoAttr *attrs, int attr_count, unsigned char **data,
                               size_t *size, SptError *e)
{
    *data = nullptr;
    *size = 0;
    try {
        auto out = ImageOutput::create(path);
        if (!out)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: no image writer for this file: %s",
                            path, oiio_reason<ImageOutput>(nullptr).c_str());
        std::vector<unsigned char> bytes;
        Filesystem::IOVecOutput vec(bytes);
        if (!out->supports("ioproxy") || !out->set_ioproxy(&vec))
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: the %s writer cannot encode to memory",
                            path, out->format_name());
        TypeDesc type = pixel_type == SPT_IMAGE_IO_U8 ? TypeDesc::UINT8 : TypeDesc::FLOAT;
        ImageSpec spec(width, height, channels, type);
        for (int i = 0; i < attr_count; ++i) {
            if (!attrs[i].name || !attrs[i].value)
                continue;
            if (!strncmp(attrs[i].name, "int:", 4))
                spec.attribute(attrs[i].name + 4, (int)strtol(attrs[i].value, nullptr, 10));
            else
                spec.attribute(attrs[i].name, attrs[i].value);
        }
        if (!out->open(path, spec))
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot encode image: %s", path,
                            oiio_reason(out.get()).c_str());
        bool ok = out->write_image(type, pixels);
        std::string why = ok ? std::string() : oiio_reason(out.get());
        if (!out->close() && ok) {
            ok = false;
            why = oiio_reason(out.get());
        }
        if (!ok)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot encode image: %s", path,
                            why.c_str());
        if (bytes.empty())
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: the encoder produced no data", path);
        unsigned char *buf = (unsigned char *)malloc(bytes.size());
        if (!buf)
            return spt_fail(e, SPT_EXIT_OUTPUT, "%s: out of memory for %zu bytes", path,
                            bytes.size());
        memcpy(buf, bytes.data(), bytes.size());
        *data = buf;
        *size = bytes.size();
        return SPT_EXIT_OK;
    } catch (const std::exception &ex) {
        return spt_fail(e, SPT_EXIT_OUTPUT, "%s: cannot encode image: %s", path, ex.what());
    }
}

extern "C" int oiio_image_info(const char *path, ImageIoInfo *info, SptError *e)
{
    try {
        memset(info, 0, sizeof *info);
        auto in = open_input(path, e);
        if (!in)
            return SPT_EXIT_INPUT;
        const ImageSpec &spec = in->spec();
        info->width = spec.width;
        info->height = spec.height;
        info->channels = spec.nchannels;
        snprintf(info->format, sizeof info->format, "%s", spec.format.c_str());
        snprintf(info->format_name, sizeof info->format_name, "%s", in->format_name());
        for (int c = 0; c < spec.nchannels && c < 8; ++c)
            snprintf(info->channel_names[c], sizeof info->channel_names[c], "%s",
                     spec.channel_name(c).c_str());
        in->close();
        return SPT_EXIT_OK;
    } catch (const std::exception &ex) {
        return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read image: %s", path, ex.what());
    }
}

extern "C" int oiio_image_read(const char *path, float **pixels, int *width, int *height,
                             int *channels, SptError *e)
{
    *pixels = nullptr;
    try {
        auto in = open_input(path, e);
        if (!in)
            return SPT_EXIT_INPUT;
        const ImageSpec &spec = in->spec();
        if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth > 1)
            return spt_fail(e, SPT_EXIT_INPUT, "%s: unsupported image size %dx%dx%d", path,
                            spec.width, spec.height, spec.nchannels);
        size_t n = (size_t)spec.width * (size_t)spec.height * (size_t)spec.nchannels;
        float *buf = (float *)malloc(n * sizeof(float));
        if (!buf)
            return spt_fail(e, SPT_EXIT_INPUT, "%s: out of memory for %zu floats", path, n);
        if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, buf)) {
            free(buf);
            return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read image: %s", path,
                            oiio_reason(in.get()).c_str());
        }
        *width = spec.width;
        *height = spec.height;
        *channels = spec.nchannels;
        *pixels = buf;
        in->close();
        return SPT_EXIT_OK;
    } catch (const std::exception &ex) {
        free(*pixels);
        *pixels = nullptr;
        return spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read image: %s", path, ex.what());
    }
}

extern "C" int oiio_image_attr(const char *path, const char *name, char *out,
                             size_t out_size, SptError *e)
{
    try {
        if (out_size)
            out[0] = 0;
        auto in = open_input(path, e);
        if (!in)
            return -1;
        const ParamValue *p = in->spec().find_attribute(name);
        if (!p)
            return 0;
        std::string s = p->type() == TypeDesc::STRING ? std::string(p->get_ustring().string())
                                                      : p->get_string(1024);
        if (out_size)
            snprintf(out, out_size, "%s", s.c_str());
        return 1;
    } catch (const std::exception &ex) {
        spt_fail(e, SPT_EXIT_INPUT, "%s: cannot read image: %s", path, ex.what());
        return -1;
    }
}
