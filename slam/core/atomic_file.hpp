#pragma once
// Replacing a file so that readers, and a crash or kill -9 at any moment, see either the whole
// previous file or the whole new one, never a part: the new content is written to a temporary
// file in the same directory (rename is atomic only within one file system), flushed to disk,
// renamed over the target, and the directory is flushed so that the rename itself survives a
// power cut. The one way coloc writes an output file (maps, trajectories, PLY, E57, images,
// YAML): a failure at any point leaves the previous file and no debris.
//
// Not thread-safe; one AtomicFile per output.
#include <filesystem>
#include <fstream>
#include <functional>
#include <iosfwd>
#include <string_view>

namespace coloc {

class AtomicFile {
 public:
  // Creates the temporary `<target>.tmp-<pid>` at once, so an output directory that is
  // missing or not writable is a coloc::Error (naming the target) before any work is done.
  // Also throws when the target is a directory.
  explicit AtomicFile(std::filesystem::path target);
  // Without commit(): removes the temporary; the target is untouched.
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::filesystem::path& target() const { return target_; }
  // Where to write the new content (closed before commit()).
  const std::filesystem::path& temp_path() const { return temp_; }
  // fsync(temporary), rename(temporary, target), fsync(directory). With sync == false the
  // rename is still atomic for other processes but may be lost in a power cut (benchmarks).
  // Throws coloc::Error naming the target on failure (the target is then untouched).
  void commit(bool sync = true);

  // Removes `<target>.tmp-<pid>` files whose process no longer runs (left by a killed save).
  static void remove_stale(const std::filesystem::path& target);

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  bool committed_ = false;
};

// An output file stream on an AtomicFile, for writers that stream text or binary records:
// write through it like any std::ofstream, then commit(). Destroyed without commit() (an
// exception on the way), the target is untouched and the temporary removed.
class AtomicOutput : public std::ofstream {
 public:
  // Claims the temporary at once (an unwritable target fails here, before any work).
  explicit AtomicOutput(std::filesystem::path target, bool sync = true,
                        std::ios::openmode mode = std::ios::out | std::ios::trunc);
  // Closes the stream; a failed stream (disk full) is a coloc::Error naming the target, which
  // then stays as it was. Otherwise renames the temporary over the target.
  void commit();
  const std::filesystem::path& target() const { return file_.target(); }

 private:
  AtomicFile file_;
  bool sync_;
};

// Writes `write(stream)` into the target atomically. A stream that fails (disk full, a write
// error) is a coloc::Error naming the target, which is then untouched. `sync` as in commit().
void write_file_atomically(const std::filesystem::path& target,
                           const std::function<void(std::ostream&)>& write, bool sync = true);
// The same for bytes already in memory (encoded images, JSON).
void write_file_atomically(const std::filesystem::path& target, std::string_view bytes,
                           bool sync = true);

}  // namespace coloc
