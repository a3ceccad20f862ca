// RGB images: PNG output through libpng and contact sheets.
#include "haustra/render/image.hpp"

#include <fmt/format.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "haustra/error.hpp"

namespace haustra::render {

Image::Image(int width, int height, Rgb fill)
    : width_(width),
      height_(height),
      pixels_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), fill) {}

void Image::paste(const Image& tile, int x, int y) {
  for (int j = 0; j < tile.height(); ++j)
    for (int i = 0; i < tile.width(); ++i)
      if (x + i >= 0 && x + i < width_ && y + j >= 0 && y + j < height_) set(x + i, y + j, tile.at(i, j));
}

void Image::save_png(const std::filesystem::path& file) const {
  auto srgb = [](float c) {
    c = std::clamp(c, 0.0f, 1.0f);
    const float s = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
    return static_cast<png_byte>(std::lround(255.0f * s));
  };
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(file.string().c_str(), "wb"), &std::fclose);
  if (!f) throw Error(ErrorCode::io, fmt::format("{}: cannot write the image", file.string()));
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (png == nullptr || info == nullptr) {
    png_destroy_write_struct(&png, &info);
    throw Error(ErrorCode::internal, "libpng: cannot start a PNG");
  }
  std::vector<png_byte> row(static_cast<std::size_t>(3 * width_));
  // libpng reports errors by longjmp: nothing with a destructor may live between here and there.
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_write_struct(&png, &info);
    throw Error(ErrorCode::io, fmt::format("{}: cannot write the PNG", file.string()));
  }
  png_init_io(png, f.get());
  png_set_IHDR(png, info, static_cast<png_uint_32>(width_), static_cast<png_uint_32>(height_), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const Rgb c = at(x, y);
      row[static_cast<std::size_t>(3 * x)] = srgb(c.r);
      row[static_cast<std::size_t>(3 * x + 1)] = srgb(c.g);
      row[static_cast<std::size_t>(3 * x + 2)] = srgb(c.b);
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

Image Image::from_srgb8(int width, int height, std::span<const std::uint8_t> rgb) {
  auto linear = [](std::uint8_t byte) {
    const float s = static_cast<float>(byte) / 255.0f;
    return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
  };
  if (rgb.size() != static_cast<std::size_t>(3 * width * height))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("from_srgb8: {} bytes for {} x {} pixels", rgb.size(), width, height));
  Image image(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t i = 3 * static_cast<std::size_t>(y * width + x);
      image.set(x, y, {linear(rgb[i]), linear(rgb[i + 1]), linear(rgb[i + 2])});
    }
  return image;
}

Image Image::load_png(const std::filesystem::path& file) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (png_image_begin_read_from_file(&png, file.string().c_str()) == 0)
    throw Error(ErrorCode::io, fmt::format("{}: cannot read the PNG ({})", file.string(), png.message));
  png.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> bytes(PNG_IMAGE_SIZE(png));
  if (png_image_finish_read(&png, nullptr, bytes.data(), 0, nullptr) == 0) {
    const std::string why = png.message;
    png_image_free(&png);
    throw Error(ErrorCode::io, fmt::format("{}: cannot read the PNG ({})", file.string(), why));
  }
  return from_srgb8(static_cast<int>(png.width), static_cast<int>(png.height), bytes);
}

Image contact_sheet(std::span<const Image> tiles, int columns) {
  if (tiles.empty()) return {};
  constexpr int kGutter = 6;
  const int rows = (static_cast<int>(tiles.size()) + columns - 1) / columns;
  const int w = tiles[0].width(), h = tiles[0].height();
  Image sheet(columns * w + (columns + 1) * kGutter, rows * h + (rows + 1) * kGutter, {1.0f, 1.0f, 1.0f});
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const int c = static_cast<int>(i) % columns, r = static_cast<int>(i) / columns;
    sheet.paste(tiles[i], kGutter + c * (w + kGutter), kGutter + r * (h + kGutter));
  }
  return sheet;
}

}  // namespace haustra::render
