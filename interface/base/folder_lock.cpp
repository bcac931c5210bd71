#include "interface/base/folder_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cosim::interface {

FolderLock::FolderLock(const std::string& folder, bool follow_links) {
  fd_ = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC | (follow_links ? 0 : O_NOFOLLOW));
  if (fd_ < 0) {
    why_ = std::strerror(errno);
    return;
  }
  if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) {
    outcome_ = Outcome::kTaken;
    return;
  }
  const int error = errno;
  outcome_ = error == EWOULDBLOCK ? Outcome::kHeldByAnotherRun : Outcome::kCannotLock;
  if (error != EWOULDBLOCK) why_ = std::strerror(error);
  ::close(fd_);
  fd_ = -1;
}

FolderLock::~FolderLock() {
  if (fd_ >= 0) ::close(fd_);  // (releases the lock)
}

bool HeldByAnotherRun(const std::string& folder) {
  return FolderLock(folder, /*follow_links=*/false).outcome() == FolderLock::Outcome::kHeldByAnotherRun;
}

}  // namespace cosim::interface
