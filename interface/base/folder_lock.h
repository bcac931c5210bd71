#pragma once
// One run per output folder (the run contract): the lock a run holds on its folder.
#include <string>

namespace cosim::interface {

// One run per output folder: an advisory lock (flock) on the folder itself, taken without
// waiting and released when the lock is destroyed or the process ends, however it ends (no lock
// file is left behind).
class FolderLock {
 public:
  enum class Outcome { kTaken, kHeldByAnotherRun, kCannotOpen, kCannotLock };
  // Tries to take the lock on `folder`; `follow_links` false refuses a link at `folder` (kCannotOpen).
  explicit FolderLock(const std::string& folder, bool follow_links = true);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

  Outcome outcome() const { return outcome_; }
  bool taken() const { return outcome_ == Outcome::kTaken; }
  // The system's reason the folder could not be opened or locked (empty if taken or held).
  const std::string& why() const { return why_; }

 private:
  int fd_ = -1;
  Outcome outcome_ = Outcome::kCannotOpen;
  std::string why_;
};

// True if `folder` (not a link) is the output folder of a running run (RunOutput's lock on it is held).
bool HeldByAnotherRun(const std::string& folder);

}  // namespace cosim::interface
