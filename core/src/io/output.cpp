// Output side of the io room: column layout shared by the writers, the checks before writing,
// and the atomic file (temporary file + fsync + rename) every writer emits into.
#include "io/detail.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <random>

namespace nhnet::io_detail {

// ---------------------------------------------------------------------------------------------
// Output helpers

[[noreturn]] void output_error(const std::string& path, const std::string& what) {
  throw OutputError(path + ": " + what);
}

void check_writable(const std::string& path, const Cloud& cloud) {
  const Eigen::Index n = cloud.points.rows();
  if (cloud.normals.rows() != 0 && cloud.normals.rows() != n)
    output_error(path, "cloud has " + std::to_string(cloud.normals.rows()) + " normals for " +
                           std::to_string(n) + " points");
  if (cloud.confidence.size() != 0 && cloud.confidence.size() != n)
    output_error(path, "cloud has " + std::to_string(cloud.confidence.size()) +
                           " confidences for " + std::to_string(n) + " points");
  if (cloud.confidence.size() != 0 && !cloud.has_normals())
    output_error(path, "cloud has confidences but no normals");
  for (const ExtraProperty& e : cloud.extras) {
    if (e.values.size() != size_t(n))
      output_error(path, "extra property '" + e.name + "' has " + std::to_string(e.values.size()) +
                             " values for " + std::to_string(n) + " points");
    const bool bad_name = e.name.empty() || std::any_of(e.name.begin(), e.name.end(), [](char c) {
                            return !std::isgraph(static_cast<unsigned char>(c));
                          });
    if (bad_name)
      output_error(path, "extra property name " + quote_token(e.name) + " is not writable");
  }
}

std::vector<const ExtraProperty*> writable_extras(const Cloud& cloud,
                                                  const std::vector<std::string>& reserved) {
  std::vector<const ExtraProperty*> out;
  std::vector<std::string> used = reserved;
  for (const ExtraProperty& e : cloud.extras) {
    if (std::find(used.begin(), used.end(), e.name) != used.end()) continue;
    used.push_back(e.name);
    out.push_back(&e);
  }
  return out;
}

std::vector<Column> cloud_columns(const Cloud& cloud, const char* const (&normal_names)[3],
                                  const std::vector<std::string>& extra_reserved) {
  std::vector<Column> cols;
  const ScalarType coord =
      points_fit_float(cloud.points) ? ScalarType::Float32 : ScalarType::Float64;
  const char* xyz[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) cols.push_back({xyz[k], coord, cloud.points.data(), k, 3});
  std::vector<std::string> reserved = {"x", "y", "z"};
  reserved.insert(reserved.end(), extra_reserved.begin(), extra_reserved.end());
  if (cloud.has_normals()) {
    for (int k = 0; k < 3; ++k) {
      cols.push_back({normal_names[k], ScalarType::Float32, cloud.normals.data(), k, 3});
      reserved.emplace_back(normal_names[k]);
    }
  }
  if (cloud.confidence.size() != 0) {  // replaces an input's extra of that name
    cols.push_back({"confidence", ScalarType::Float32, cloud.confidence.data(), 0, 1});
    reserved.emplace_back("confidence");
  }
  for (const ExtraProperty* e : writable_extras(cloud, reserved))
    cols.push_back({e->name, e->type, e->values.data(), 0, 1});
  return cols;
}

void write_rows(Sink& sink, const std::vector<Column>& cols, Eigen::Index rows, bool ascii,
                std::string& out) {
  for (Eigen::Index i = 0; i < rows; ++i) {
    for (size_t c = 0; c < cols.size(); ++c) {
      const double v = cols[c].values[cols[c].first + i * cols[c].stride];
      if (ascii) {
        if (c > 0) out += ' ';
        append_number(v, cols[c].type, out);
      } else {
        encode_scalar_le(v, cols[c].type, out);
      }
    }
    if (ascii) out += '\n';
    if (out.size() >= (size_t(1) << 16)) {
      sink.write(out);
      out.clear();
    }
  }
  sink.write(out);
}

// ---------------------------------------------------------------------------------------------
// Atomic writing

AtomicFile::AtomicFile(const std::string& target) : target_(target) {
  namespace fs = std::filesystem;
  const fs::path p(target);
  if (p.filename().empty()) output_error(target, "not a file name");
  fs::path dir = p.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    output_error(target, "directory '" + dir.string() + "' does not exist");
  if (fs::is_directory(p, ec)) output_error(target, std::strerror(EISDIR));
  open_temp(dir, p.filename().string());
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::write(const char* data, size_t size) {
  buffer_.append(data, size);
  if (buffer_.size() >= kFlushBytes) flush();
}

void AtomicFile::commit() {
  flush();
  if (::fsync(fd_) != 0) fail("fsync failed");
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("close failed");
  if (::rename(temp_.c_str(), target_.c_str()) != 0) fail("rename failed");
  committed_ = true;
  sync_directory();
}

void AtomicFile::fail(const std::string& what) {
  const int err = errno;
  output_error(target_, what + ": " + std::strerror(err));
}

// Creates `<dir>/.<name>.nhnet-tmp-<pid>-<random>` exclusively; keeps an existing target's
// permission bits.
void AtomicFile::open_temp(const std::filesystem::path& dir, const std::string& name) {
  std::random_device device;
  for (int attempt = 0; attempt < 16 && fd_ < 0; ++attempt) {
    const uint64_t r = (uint64_t(device()) << 32) ^ device();
    char suffix[32];
    const auto end = std::to_chars(suffix, suffix + sizeof(suffix), r, 16).ptr;
    temp_ = (dir / ("." + name + ".nhnet-tmp-" + std::to_string(::getpid()) + "-" +
                    std::string(suffix, end)))
                .string();
    fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ < 0 && errno != EEXIST) {
      temp_.clear();
      fail("cannot create a file in '" + dir.string() + "'");
    }
  }
  if (fd_ < 0) {
    temp_.clear();
    output_error(target_, "cannot create a unique temporary file");
  }
  struct stat st {};
  if (::stat(target_.c_str(), &st) == 0 && S_ISREG(st.st_mode))
    ::fchmod(fd_, st.st_mode & 07777);  // best effort: keep the original's permissions
}

// Writes the buffer out completely (retrying short writes and EINTR).
void AtomicFile::flush() {
  size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail("write failed");
    if (n == 0) {
      errno = ENOSPC;
      fail("write failed");
    }
    done += size_t(n);
  }
  buffer_.clear();
}

// Makes the rename durable; failures are ignored (the data itself is already synced).
void AtomicFile::sync_directory() {
  std::filesystem::path dir = std::filesystem::path(target_).parent_path();
  if (dir.empty()) dir = ".";
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) return;
  (void)::fsync(dfd);
  ::close(dfd);
}

}  // namespace nhnet::io_detail
