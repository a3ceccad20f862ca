// Replays fuzz inputs without libFuzzer: each argument is a file or a folder of files, each file is
// fed once to the target's LLVMFuzzerTestOneInput. Built with the normal compiler, so the
// committed corpus and every crash found so far run in `make test` (and under ASan+UBSan there).
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

// `--every N FOLDER` replays every N-th file of that folder (in name order): the sanitizer builds
// take a sample of a large corpus whose every input the release build and the fuzzer itself run.
int main(int argc, char** argv) {
  std::vector<std::filesystem::path> files;
  for (int i = 1; i < argc; ++i) {
    std::size_t every = 1;
    if (std::string(argv[i]) == "--every" && i + 2 < argc) {
      every = static_cast<std::size_t>(std::max(1, std::atoi(argv[i + 1])));
      i += 2;
    }
    const std::filesystem::path p = argv[i];
    if (std::filesystem::is_directory(p)) {
      std::vector<std::filesystem::path> in_folder;
      for (const auto& e : std::filesystem::directory_iterator(p))
        if (e.is_regular_file()) in_folder.push_back(e.path());
      std::sort(in_folder.begin(), in_folder.end());
      for (std::size_t k = 0; k < in_folder.size(); k += every) files.push_back(in_folder[k]);
    } else if (std::filesystem::exists(p)) {
      files.push_back(p);
    } else {
      std::fprintf(stderr, "replay: %s: no such file or folder\n", p.c_str());
      return 2;
    }
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("replay: %zu inputs, none crashed\n", files.size());
  return files.empty() ? 1 : 0;
}
