#pragma once
// An RGB image in memory, written as PNG; a contact sheet of several.
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace haustra::render {

struct Rgb {
  float r = 0.0f, g = 0.0f, b = 0.0f;  // linear, 0..1
};

class Image {
 public:
  Image() = default;
  Image(int width, int height, Rgb fill = {});
  [[nodiscard]] int width() const { return width_; }
  [[nodiscard]] int height() const { return height_; }
  [[nodiscard]] Rgb at(int x, int y) const { return pixels_[static_cast<std::size_t>(y * width_ + x)]; }
  void set(int x, int y, Rgb c) { pixels_[static_cast<std::size_t>(y * width_ + x)] = c; }
  // Writes 8-bit sRGB. Throws Error{io} naming the file.
  void save_png(const std::filesystem::path& file) const;
  // Reads an 8-bit PNG (any colour type; alpha dropped) into linear values. Throws Error{io}.
  static Image load_png(const std::filesystem::path& file);
  // From 8-bit sRGB rows, top row first (a screenshot's bytes), 3 bytes per pixel.
  static Image from_srgb8(int width, int height, std::span<const std::uint8_t> rgb);
  // Pastes `tile` with its top-left corner at (x, y), clipped.
  void paste(const Image& tile, int x, int y);

 private:
  int width_ = 0, height_ = 0;
  std::vector<Rgb> pixels_;
};

// Tiles in rows of `columns`, separated by a thin white gutter.
Image contact_sheet(std::span<const Image> tiles, int columns);

}  // namespace haustra::render
