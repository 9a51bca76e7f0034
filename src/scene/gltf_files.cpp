// The glTF loader's file access: tinygltf reads external buffers and images
// through these callbacks, so no file outside the scene's folder is ever opened.
#include "scene/gltf_loader.h"

namespace spt_gltf {

bool Loader::inside_folder(const std::string &path, std::string *real_out)
{
    char *real = realpath(path.c_str(), nullptr);
    if (!real) return false;
    std::string r(real);
    free(real);
    if (real_out) *real_out = r;
    return r.size() > dir_real.size() && r.compare(0, dir_real.size(), dir_real) == 0 &&
           (r[dir_real.size()] == '/' || dir_real == "/");
}

bool fs_exists(const std::string &path, void *user)
{
    Loader *L = (Loader *)user;
    struct stat st;
    if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
    if (!L->inside_folder(path, nullptr)) {
        L->refused.push_back(path);
        return false;
    }
    return true;
}

std::string fs_expand(const std::string &path, void *) { return path; }

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &path,
             void *user)
{
    Loader *L = (Loader *)user;
    if (!L->inside_folder(path, nullptr)) {
        if (err) *err = "outside the scene folder";
        return false;
    }
    unsigned char *bytes = nullptr;
    size_t size = 0;
    SptError e = {};
    if (input_read(path.c_str(), "file", &bytes, &size, &e)) {
        // The reason after "PATH: ": tinygltf names the file itself.
        const char *why = strstr(e.msg, ": ");
        if (err) *err = why ? why + 2 : e.msg;
        return false;
    }
    try {
        out->assign(bytes, bytes + size);
    } catch (...) {
        free(bytes);
        if (err) *err = "does not fit in memory";
        return false;
    }
    free(bytes);
    // tinygltf refuses the whole file when an image file is empty; one zero byte
    // turns that into a corrupt image (a warning), and a buffer still fails its
    // size check.
    if (out->empty()) out->push_back(0);
    return true;
}

bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *)
{
    if (err) *err = "writing is not supported";
    return false;
}

// Keeps the encoded bytes of data-URI images; external files and buffer views
// are decoded later, after their ranges and paths have been checked.
bool keep_image_bytes(tinygltf::Image *image, const int index, std::string *, std::string *, int,
                      int, const unsigned char *bytes, int size, void *user)
{
    Loader *L = (Loader *)user;
    if (image->bufferView == -1 && image->uri.empty() && bytes && size > 0)
        L->data_uri_images[index].assign(bytes, bytes + size);
    return true;
}

} // namespace spt_gltf
