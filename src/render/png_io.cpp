// Image as PNG files, through Cairo: written atomically, read within the image size limit.
#include <cairo.h>

#include <cstring>
#include <string>

#include "canvas.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/render/image.hpp"

namespace tsdf_mcl {

using detail::ImageAccess;
using render::Canvas;
using Box = Eigen::AlignedBox2d;

void save_png(const Image& image, const std::filesystem::path& file) {
  if (image.empty()) throw Error("cannot write image " + file.string() + ": the image is empty");
  std::error_code ec;
  const auto parent = file.parent_path();
  if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) {
    throw Error("cannot write image " + file.string() + ": folder " + parent.string() + " does not exist");
  }
  // Cairo only reads the pixels here.
  auto* data = reinterpret_cast<unsigned char*>(const_cast<std::uint32_t*>(ImageAccess::xrgb(image)));
  cairo_surface_t* surface =
      cairo_image_surface_create_for_data(data, CAIRO_FORMAT_RGB24, image.width(), image.height(), image.width() * 4);
  std::string encoded;
  const auto append = [](void* closure, const unsigned char* bytes, unsigned int length) {
    static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(bytes), length);
    return CAIRO_STATUS_SUCCESS;
  };
  const cairo_status_t status = cairo_surface_write_to_png_stream(surface, append, &encoded);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS) {
    throw Error("cannot write image " + file.string() + ": PNG encoding failed (" + cairo_status_to_string(status) +
                ")");
  }
  write_file_atomically(file, encoded, "image");
}

Image load_png(const std::filesystem::path& file) {
  // Even RGBA that does not compress takes about 4 bytes a pixel: a larger file holds no 8-bit image within the limit.
  constexpr std::uint64_t kMaxBytes = std::uint64_t{4} * kMaxImageSide * kMaxImageSide;
  const std::string bytes = read_input_file(file, "image", kMaxBytes);
  struct Reader {
    const std::string& bytes;
    std::size_t offset = 0;
  } reader{bytes};
  const auto read = [](void* closure, unsigned char* data, unsigned int length) {
    auto& r = *static_cast<Reader*>(closure);
    if (r.bytes.size() - r.offset < length) return CAIRO_STATUS_READ_ERROR;
    std::memcpy(data, r.bytes.data() + r.offset, length);
    r.offset += length;
    return CAIRO_STATUS_SUCCESS;
  };
  cairo_surface_t* png = cairo_image_surface_create_from_png_stream(read, &reader);
  const cairo_status_t status = cairo_surface_status(png);
  if (status != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(png);
    const bool corrupt = status == CAIRO_STATUS_READ_ERROR || status == CAIRO_STATUS_PNG_ERROR;
    throw Error("cannot read image " + file.string() + ": " +
                (corrupt ? std::string("not a PNG file, or a corrupt one") : cairo_status_to_string(status)));
  }
  Image image;
  try {
    image = Image(cairo_image_surface_get_width(png), cairo_image_surface_get_height(png));
  } catch (const Error& e) {
    cairo_surface_destroy(png);
    throw Error("cannot read image " + file.string() + ": " + e.what());
  }
  {
    const Canvas canvas(image, Box(Eigen::Vector2d::Zero(), Eigen::Vector2d(image.width(), image.height())));
    cairo_set_source_surface(canvas.cr(), png, 0.0, 0.0);
    cairo_paint(canvas.cr());
  }
  cairo_surface_destroy(png);
  return image;
}

}  // namespace tsdf_mcl
