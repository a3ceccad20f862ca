// Screenshots and videos of the window (glReadPixels; ffmpeg through a pipe for videos).
#include "capture.hpp"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#include <fmt/format.h>

#include <algorithm>
#include <csignal>
#include <filesystem>

#include "haustra/error.hpp"
#include "haustra/render/image.hpp"

namespace haustra::view {

std::vector<std::uint8_t> read_pixels(int width, int height) {
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(3 * width * height));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
  std::vector<std::uint8_t> top_down(rgb.size());  // GL's rows start at the bottom
  const std::size_t row = static_cast<std::size_t>(3 * width);
  for (int y = 0; y < height; ++y)
    std::copy_n(rgb.begin() + static_cast<std::ptrdiff_t>(row * static_cast<std::size_t>(height - 1 - y)), row,
                top_down.begin() + static_cast<std::ptrdiff_t>(row * static_cast<std::size_t>(y)));
  return top_down;
}

void save_screenshot(const std::string& path, int width, int height) {
  if (const auto dir = std::filesystem::path(path).parent_path(); !dir.empty())
    std::filesystem::create_directories(dir);
  render::Image::from_srgb8(width, height, read_pixels(width, height)).save_png(path);
}

VideoRecorder::~VideoRecorder() {
  if (pipe_ != nullptr) pclose(pipe_);
}

void VideoRecorder::start(const std::string& path, int width, int height, double fps) {
  if (pipe_ != nullptr) stop();
  if (const auto dir = std::filesystem::path(path).parent_path(); !dir.empty())
    std::filesystem::create_directories(dir);
  // The window's frames as they come, its size cut to even (H.264's 4:2:0 wants it), at the
  // simulated time's rate.
  const std::string command = fmt::format(
      "ffmpeg -loglevel error -y -f rawvideo -pix_fmt rgb24 -video_size {}x{} -framerate {:.6f} -i - "
      "-vf 'crop=trunc(iw/2)*2:trunc(ih/2)*2' -pix_fmt yuv420p '{}'",
      width, height, fps, path);
  if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0)
    throw Error(ErrorCode::io, "a video needs ffmpeg (scripts/install-deps.sh installs it: apt-get install ffmpeg)");
  // ffmpeg failing must not kill the window with SIGPIPE: a write that fails stops the video.
  std::signal(SIGPIPE, SIG_IGN);
  pipe_ = popen(command.c_str(), "w");
  if (pipe_ == nullptr) throw Error(ErrorCode::io, fmt::format("{}: cannot start ffmpeg", path));
  path_ = path;
  width_ = width;
  height_ = height;
  frames_ = 0;
}

bool VideoRecorder::add(int width, int height) {
  if (pipe_ == nullptr) return false;
  if (width != width_ || height != height_) return false;
  const std::vector<std::uint8_t> rgb = read_pixels(width, height);
  if (std::fwrite(rgb.data(), 1, rgb.size(), pipe_) != rgb.size()) return false;
  ++frames_;
  return true;
}

std::size_t VideoRecorder::stop() {
  if (pipe_ == nullptr) return frames_;
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  if (status != 0) throw Error(ErrorCode::io, fmt::format("{}: ffmpeg failed (status {})", path_, status));
  return frames_;
}

}  // namespace haustra::view
