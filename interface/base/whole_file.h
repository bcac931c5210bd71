#pragma once
// Files a run writes whole or not at all (its summary, its saved state, the visual indexes).
#include <functional>
#include <ostream>
#include <string>

namespace cosim::interface {

// The outcome of WriteWholeFile: ok(), or `why` naming the file and the system's reason.
struct WrittenFile {
  std::string why;
  bool ok() const { return why.empty(); }
};

// Writes a file whole or not at all: `write` fills a temporary beside `path` (`path`.part), which
// is renamed over `path` once it is complete. If anything fails (the temporary cannot be made, a
// write fails on a full disk, the rename is refused) the temporary is removed, `path` is left as it
// was, and the outcome says why. A process stopped while it writes leaves at most the temporary,
// never half a file taken for the whole one; a link at `path` is replaced, not written through.
// `write` may set the stream's failbit to say its own content could not be made.
[[nodiscard]] WrittenFile WriteWholeFile(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace cosim::interface
