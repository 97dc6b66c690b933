#include "slam/core/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>

#include "slam/core/error.hpp"

namespace coloc {

namespace fs = std::filesystem;

namespace {

std::string errno_text() {
  return std::strerror(errno);
}

fs::path directory_of(const fs::path& target) {
  const fs::path dir = target.parent_path();
  return dir.empty() ? fs::path(".") : dir;
}

void fsync_path(const fs::path& path, int flags, const fs::path& target) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) throw Error("cannot open " + path.string() + ": " + errno_text(), {target.string()});
  const int rc = ::fsync(fd);
  const int saved = errno;
  ::close(fd);
  if (rc != 0)
    throw Error("fsync of " + path.string() + " failed: " + std::strerror(saved),
                {target.string()});
}

}  // namespace

AtomicFile::AtomicFile(fs::path target) : target_(std::move(target)) {
  const fs::path dir = directory_of(target_);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw Error("the output directory " + dir.string() + " does not exist", {target_.string()});
  if (fs::is_directory(target_, ec))
    throw Error("the output is a directory, not a file", {target_.string()});
  temp_ = target_;
  temp_ += ".tmp-" + std::to_string(::getpid());
  ::unlink(temp_.c_str());  // a leftover of an earlier process that had our pid
  const int fd = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0)
    throw Error("cannot write into " + dir.string() + ": " + errno_text(), {target_.string()});
  ::close(fd);
}

AtomicFile::~AtomicFile() {
  if (!committed_) ::unlink(temp_.c_str());
}

void AtomicFile::commit(bool sync) {
  if (committed_) throw Error("AtomicFile: committed twice", {target_.string()});
  if (sync) fsync_path(temp_, O_RDONLY, target_);
  if (::rename(temp_.c_str(), target_.c_str()) != 0)
    throw Error("cannot replace the file: " + errno_text(), {target_.string()});
  committed_ = true;
  if (sync) fsync_path(directory_of(target_), O_RDONLY | O_DIRECTORY, target_);
}

void AtomicFile::remove_stale(const fs::path& target) {
  const std::string prefix = target.filename().string() + ".tmp-";
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(directory_of(target), ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.empty() || digits.size() > 9 ||
        digits.find_first_not_of("0123456789") != std::string::npos)
      continue;
    const long pid = std::stol(digits);
    // kill(pid, 0) fails with ESRCH only when no such process exists; EPERM means it runs.
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      fs::remove(entry.path(), ec);
    }
  }
}

AtomicOutput::AtomicOutput(fs::path target, bool sync, std::ios::openmode mode)
    : file_(std::move(target)), sync_(sync) {
  open(file_.temp_path(), mode);
  if (!is_open())
    throw Error("cannot open " + file_.temp_path().string(), {file_.target().string()});
}

void AtomicOutput::commit() {
  close();
  if (fail()) throw Error("writing failed (disk full?)", {file_.target().string()});
  file_.commit(sync_);
}

void write_file_atomically(const fs::path& target, const std::function<void(std::ostream&)>& write,
                           bool sync) {
  AtomicOutput out(target, sync, std::ios::binary | std::ios::trunc);
  write(out);
  out.commit();
}

void write_file_atomically(const fs::path& target, std::string_view bytes, bool sync) {
  write_file_atomically(
      target,
      [bytes](std::ostream& out) {
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
      },
      sync);
}

}  // namespace coloc
