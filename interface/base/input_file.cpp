#include "interface/base/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cosim::interface {

namespace {

// Closes a descriptor on every path out.
class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

std::string FileKind(unsigned mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  return "not a regular file";
}

InputFile ReadInputFile(const std::filesystem::path& path, std::int64_t max_bytes) {
  InputFile f;
  const std::string name = "'" + path.string() + "'";
  auto cannot_read = [&] {
    f.problem = InputFile::Problem::kCannotRead;
    f.detail = std::strerror(errno);
    f.why = name + " cannot be read: " + f.detail;
    f.text.clear();
    return f;
  };
  // O_NONBLOCK: a FIFO opens at once (and is refused below) instead of waiting for a writer.
  const Descriptor fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY));
  struct stat info {};
  if (fd.get() < 0 || ::fstat(fd.get(), &info) != 0) return cannot_read();
  if (!S_ISREG(info.st_mode)) {
    f.problem = InputFile::Problem::kNotRegular;
    f.detail = FileKind(info.st_mode);
    f.why = name + " is " + f.detail + (f.detail == "not a regular file" ? "" : ", not a regular file");
    return f;
  }
  if (info.st_size > max_bytes) {
    f.problem = InputFile::Problem::kTooLarge;
    f.size = info.st_size;
    f.why =
        name + " has " + std::to_string(info.st_size) + " bytes; at most " + std::to_string(max_bytes) + " are read";
    return f;
  }
  f.text.resize(static_cast<size_t>(info.st_size));
  size_t got = 0;
  while (got < f.text.size()) {
    const ssize_t n = ::read(fd.get(), f.text.data() + got, f.text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return cannot_read();
    if (n == 0) break;  // (shorter than when it was measured: what is there)
    got += static_cast<size_t>(n);
  }
  f.text.resize(got);
  f.problem = InputFile::Problem::kNone;
  return f;
}

}  // namespace cosim::interface
