// Thin C++17 shim: mgs_image_read / mgs_image_write over OpenImageIO.
#include <OpenImageIO/imageio.h>

#include <atomic>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

extern "C" {
#include "core/mgs_image.h"
}

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {
// Larger images than this are refused rather than risking a huge allocation from a
// corrupt header.
constexpr long long kMaxPixels = 1LL << 28;

std::string lower_ext(const std::string &path) {
  size_t slash = path.find_last_of('/');
  size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot + 1);
  for (char &c : e) c = (char)std::tolower((unsigned char)c);
  return e;
}

// Only regular files are handed to OIIO (a FIFO or /dev/zero would block or never end).
mgs_status check_regular(const char *path, mgs_error *err) {
  struct stat st;
  if (stat(path, &st) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: image file not found", path);
  if (!S_ISREG(st.st_mode)) return mgs_error_set(err, MGS_ERR_IO, "%s: not a regular file", path);
  return MGS_OK;
}

// A temporary name beside `path` that keeps its extension (OIIO picks the writer by it);
// unique per process and call, as views are written from parallel loops.
std::string temp_name(const std::string &path) {
  size_t slash = path.find_last_of('/');
  std::string dir = slash == std::string::npos ? "" : path.substr(0, slash + 1);
  std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  static std::atomic<long> counter{0};
  return dir + ".tmp-" + std::to_string((long)getpid()) + "-" + std::to_string(counter++) + "-" + base;
}

// OIIO keeps its own worker pool; the project's parallelism is TBB's (mgs_parallel_for),
// which calls these functions from its workers, so OIIO runs each call on the caller.
void init_oiio_once() {
  static std::once_flag once;
  std::call_once(once, [] { OIIO::attribute("threads", 1); });
}
}  // namespace

// Straight (unassociated) alpha, as PIL gives the reference: OIIO would otherwise
// premultiply PNG colours by alpha on read and divide on write.
static ImageSpec straight_alpha_config() {
  ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  return config;
}

extern "C" mgs_status mgs_image_read(const char *path, mgs_image **out, mgs_error *err) {
  *out = nullptr;
  init_oiio_once();
  if (mgs_status st = check_regular(path, err)) return st;
  ImageSpec config = straight_alpha_config();
  auto in = ImageInput::open(path, &config);
  if (!in) {
    std::string e = OIIO::geterror();
    if (access(path, F_OK) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: image file not found", path);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read image: %s", path, e.empty() ? "unknown format" : e.c_str());
  }
  const ImageSpec &spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.nchannels > 64 || spec.depth > 1 ||
      (long long)spec.width * spec.height > kMaxPixels)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header claims %dx%d pixels with %d channels (this reader takes up to %lld pixels and 64 channels)",
                         path, spec.width, spec.height, spec.nchannels, kMaxPixels);
  mgs_image *img = mgs_image_create(spec.width, spec.height, spec.nchannels);
  if (!img) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for a %dx%d image", path, spec.width, spec.height);
  if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, img->data)) {
    std::string e = in->geterror();
    mgs_image_destroy(img);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot decode image: %s", path, e.c_str());
  }
  in->close();
  *out = img;
  return MGS_OK;
}

extern "C" mgs_status mgs_image_read_size(const char *path, int *width, int *height, int *channels, mgs_error *err) {
  *width = *height = *channels = 0;
  init_oiio_once();
  if (mgs_status st = check_regular(path, err)) return st;
  auto in = ImageInput::open(path);
  if (!in) {
    std::string e = OIIO::geterror();
    if (access(path, F_OK) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: image file not found", path);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read image: %s", path, e.empty() ? "unknown format" : e.c_str());
  }
  const ImageSpec &spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.nchannels > 64 || spec.depth > 1 ||
      (long long)spec.width * spec.height > kMaxPixels)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header claims %dx%d pixels with %d channels (this reader takes up to %lld pixels and 64 channels)",
                         path, spec.width, spec.height, spec.nchannels, kMaxPixels);
  *width = spec.width;
  *height = spec.height;
  *channels = spec.nchannels;
  return MGS_OK;
}

namespace {
mgs_status write_image(const char *path, const mgs_image *img, bool u16, mgs_error *err);
}

extern "C" mgs_status mgs_image_write(const char *path, const mgs_image *img, mgs_error *err) {
  return write_image(path, img, false, err);
}

extern "C" mgs_status mgs_image_write_u16(const char *path, const mgs_image *img, mgs_error *err) {
  return write_image(path, img, true, err);
}

namespace {
mgs_status write_image(const char *path, const mgs_image *img, bool u16, mgs_error *err) {
  if (!img || !img->data || img->width <= 0 || img->height <= 0 || img->channels <= 0)
    return mgs_error_set(err, MGS_ERR_ARG, "%s: no image to write", path);
  init_oiio_once();
  std::string p(path), ext = lower_ext(p);
  auto out = ImageOutput::create(p);
  if (!out) return mgs_error_set(err, MGS_ERR_ARG, "%s: no image writer for this extension", path);
  const bool is_float = ext == "exr" || ext == "hdr" || ext == "tif" || ext == "tiff";
  ImageSpec spec(img->width, img->height, img->channels,
                 is_float ? TypeDesc::FLOAT : u16 ? TypeDesc::UINT16 : TypeDesc::UINT8);
  if (img->channels == 4) spec.alpha_channel = 3;
  spec.attribute("oiio:UnassociatedAlpha", 1);
  std::string tmp = temp_name(p);
  if (!out->open(tmp, spec)) {
    std::string e = out->geterror();
    std::remove(tmp.c_str());
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write: %s", path, e.c_str());
  }
  // OIIO converts float to 8 bits with clamping and rounding.
  bool ok = out->write_image(TypeDesc::FLOAT, img->data);
  std::string e = ok ? "" : out->geterror();
  ok = out->close() && ok;
  if (!ok) {
    std::remove(tmp.c_str());
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write: %s", path, e.c_str());
  }
  if (std::rename(tmp.c_str(), path) != 0) {
    std::remove(tmp.c_str());
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot rename the temporary file into place", path);
  }
  return MGS_OK;
}
}  // namespace
