#include "interface/base/whole_file.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace cosim::interface {

WrittenFile WriteWholeFile(const std::string& path, const std::function<void(std::ostream&)>& write) {
  const std::string temporary = path + ".part";
  WrittenFile result;
  {
    errno = 0;
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) {
      result.why = "cannot write " + path + ": " + std::strerror(errno != 0 ? errno : EIO);
    } else {
      errno = 0;
      write(out);
      int error = out ? 0 : errno;  // (a write that failed as it went)
      out.close();                  // (flushes: a full disk shows here at the latest)
      if (!out) {
        if (error == 0) error = errno;
        result.why = "cannot write " + path + ": " +
                     (error != 0 ? std::string(std::strerror(error)) : "writing failed (is the disk full?)");
      }
    }
  }
  std::error_code ec;
  if (result.ok()) {
    std::filesystem::rename(temporary, path, ec);
    if (ec) result.why = "cannot write " + path + ": " + ec.message();
  }
  if (!result.ok()) std::filesystem::remove(temporary, ec);
  return result;
}

}  // namespace cosim::interface
