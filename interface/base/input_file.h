#pragma once
// One reader for every file a run reads: the scenario and its includes, the files a scenario
// names (CSV tables, C81 airfoils, airwake grids, saved states) and the files a run reads back
// (its processes' histories and summaries, a visual index).
//
// A file is read only if it is a regular file (after links) of at most `max_bytes`: it is opened
// without blocking (a FIFO without a writer would block open() for ever), checked on the open
// descriptor (no race between the check and the read), and read up to its size (a link to
// /dev/zero or /dev/full would be read until memory runs out).
#include <cstdint>
#include <filesystem>
#include <string>

namespace cosim::interface {

// Bounds of the files a run reads: above them a file is refused before it is read.
inline constexpr std::int64_t kMaxTableBytes = 256LL << 20;   // CSV tables, airwake grids
inline constexpr std::int64_t kMaxAirfoilBytes = 16LL << 20;  // C81 airfoil tables
inline constexpr std::int64_t kMaxStateBytes = 1LL << 30;     // saved states (final_state.pb)
inline constexpr std::int64_t kMaxOutputBytes = 4LL << 30;    // a run's own histories, read back

// The outcome of ReadInputFile: `text` the file's bytes if ok(), else what went wrong: `problem`,
// with `detail` (the system's reason it cannot be read, or what the file is instead: FileKind)
// and `size` (a file too large), and `why` saying it in words a user can act on ("'P' is a FIFO,
// not a regular file", "'P' has N bytes; at most M are read", "'P' cannot be read: No such file or
// directory"). No file content is quoted.
struct InputFile {
  enum class Problem { kNone, kCannotRead, kNotRegular, kTooLarge };
  Problem problem = Problem::kCannotRead;
  std::string text;
  std::string detail;
  std::int64_t size = 0;
  std::string why;
  bool ok() const { return problem == Problem::kNone; }
};

[[nodiscard]] InputFile ReadInputFile(const std::filesystem::path& path, std::int64_t max_bytes);

// What a non-regular file is, in words ("a folder", "a FIFO", "a character device", …).
std::string FileKind(unsigned mode);

}  // namespace cosim::interface
