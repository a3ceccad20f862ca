#pragma once
// Capturing the window: a PNG of the frame drawn, and a video of frames at the physics' own time
// (ffmpeg, from Debian, fed raw RGB through a pipe).
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace haustra::view {

// The back buffer's pixels, top row first, 8-bit RGB.
std::vector<std::uint8_t> read_pixels(int width, int height);
void save_screenshot(const std::string& path, int width, int height);

// A video being written: one frame per call, at a fixed rate (frames of simulated time).
class VideoRecorder {
 public:
  VideoRecorder() = default;
  ~VideoRecorder();
  VideoRecorder(const VideoRecorder&) = delete;
  VideoRecorder& operator=(const VideoRecorder&) = delete;

  // Starts ffmpeg writing `path` (H.264 in MP4, or whatever its extension says) at `fps`;
  // throws haustra::Error when ffmpeg cannot be started. width and height: the window's, kept
  // for the whole video (an odd size is cut to an even one).
  void start(const std::string& path, int width, int height, double fps);
  // A frame; false (and the video stopped) when the window's size changed or ffmpeg failed.
  bool add(int width, int height);
  // Closes the video; returns the frames written (throws haustra::Error when ffmpeg failed).
  std::size_t stop();
  [[nodiscard]] bool recording() const { return pipe_ != nullptr; }
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] std::size_t frames() const { return frames_; }

 private:
  std::FILE* pipe_ = nullptr;
  std::string path_;
  int width_ = 0, height_ = 0;
  std::size_t frames_ = 0;
};

}  // namespace haustra::view
