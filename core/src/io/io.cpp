// Point cloud io entry points: reading the file, sniffing its format and dispatching to the
// format readers (ply.cpp, pcd.cpp, xyz.cpp, las.cpp, e57.cpp) and writers, which emit into an
// AtomicFile (output.cpp).
#include "nhnet/io/io.hpp"

#include "io/detail.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace nhnet {

using namespace io_detail;

// ---------------------------------------------------------------------------------------------
// Reading

/// Lower-case extension of `path` including the dot ("" when none).
static std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

FileFormat format_from_extension(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return FileFormat::Ply;
  if (ext == ".pcd") return FileFormat::Pcd;
  if (ext == ".xyz" || ext == ".xyzn" || ext == ".txt" || ext == ".pts") return FileFormat::Xyz;
  if (ext == ".las") return FileFormat::Las;
  if (ext == ".laz") return FileFormat::Laz;
  if (ext == ".e57") return FileFormat::E57;
  return FileFormat::Auto;
}

/// Reads the whole file; InputError with the strerror text when it cannot be opened or read.
static FileBytes load_file(const std::string& path) {
  FileBytes file{path, {}};
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) input_error(path, std::strerror(EISDIR));
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) input_error(path, std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0)
    file.bytes.reserve(size_t(st.st_size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t got = ::read(fd, buffer, sizeof(buffer));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const int err = errno;
      ::close(fd);
      input_error(path, std::string("read failed: ") + std::strerror(err));
    }
    if (got == 0) break;
    file.bytes.append(buffer, size_t(got));
  }
  ::close(fd);
  return file;
}

/// True when the first line that is neither blank nor a '#' comment consists of numbers only
/// (at least one), looking at the first 4 KiB.
static bool looks_numeric(const std::string& bytes) {
  LineCursor lines(std::string_view(bytes).substr(0, 4096), 0, 1);
  std::string_view line;
  while (lines.next(line)) {
    Tokens tokens(line);
    std::string_view token;
    if (!tokens.next(token) || token[0] == '#') continue;
    do {
      double v = 0;
      if (!parse_double(token, v)) return false;
    } while (tokens.next(token));
    return true;
  }
  return false;
}

static bool starts_with(const std::string& s, std::string_view prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

/// Format of the content: magic line first, then the extension, then "is it numbers".
static FileFormat sniff(const FileBytes& file, std::vector<std::string>* warnings) {
  const std::string& b = file.bytes;
  if (starts_with(b, "ply\n") || starts_with(b, "ply\r")) return FileFormat::Ply;
  if (starts_with(b, "# .PCD") || starts_with(b, "VERSION") || starts_with(b, "FIELDS"))
    return FileFormat::Pcd;
  if (starts_with(b, "LASF")) return FileFormat::Las;
  if (starts_with(b, "ASTM-E57")) return FileFormat::E57;
  const FileFormat by_extension = format_from_extension(file.path);
  if (by_extension == FileFormat::Xyz) return FileFormat::Xyz;
  if (looks_numeric(b)) {
    if (by_extension != FileFormat::Auto)
      warn(warnings, "content is XYZ text despite the " + lower_extension(file.path) +
                         " extension; read as XYZ");
    return FileFormat::Xyz;
  }
  if (by_extension == FileFormat::Ply)
    input_error(file.path, "not a PLY file (bad magic: the first line is not 'ply')");
  if (by_extension == FileFormat::Pcd)
    input_error(file.path, "not a PCD file (bad magic: no '# .PCD' or VERSION header line)");
  if (by_extension == FileFormat::Las || by_extension == FileFormat::Laz)
    input_error(file.path, "not a LAS/LAZ file (bad magic: it does not start with 'LASF')");
  if (by_extension == FileFormat::E57)
    input_error(file.path, "not an E57 file (bad magic: it does not start with 'ASTM-E57')");
  input_error(file.path, "unrecognised format (not PLY, PCD, XYZ text, LAS/LAZ or E57)");
}

Cloud read_cloud(const std::string& path, const ReadOptions& options,
                 std::vector<std::string>* warnings) {
  const FileBytes file = load_file(path);
  if (file.bytes.empty()) input_error(path, "empty file");
  const FileFormat format =
      options.format == FileFormat::Auto ? sniff(file, warnings) : options.format;
  switch (format) {
    case FileFormat::Ply: return read_ply(file, warnings);
    case FileFormat::Pcd: return read_pcd(file, warnings);
    case FileFormat::Xyz: return read_xyz(file, warnings);
    case FileFormat::Las:
    case FileFormat::Laz: return read_las(file, warnings);
    case FileFormat::E57: return read_e57(file, warnings);
    case FileFormat::Auto: break;
  }
  input_error(path, "unrecognised format");
}

// ---------------------------------------------------------------------------------------------
// Writing

void write_cloud(const std::string& path, const Cloud& cloud, const WriteOptions& options) {
  const FileFormat format =
      options.format == FileFormat::Auto ? format_from_extension(path) : options.format;
  if (format == FileFormat::Auto)
    output_error(path,
                 "cannot tell the output format from the extension (use .ply, .pcd, .xyz, .las, "
                 ".laz, .e57)");
  check_writable(path, cloud);
  AtomicFile file(path);
  switch (format) {
    case FileFormat::Ply: write_ply(file, cloud, options.ascii); break;
    case FileFormat::Pcd: write_pcd(file, cloud, options.ascii); break;
    case FileFormat::Xyz: write_xyz(file, cloud); break;
    case FileFormat::Las: write_las(file, cloud, false, path); break;
    case FileFormat::Laz: write_las(file, cloud, true, path); break;
    case FileFormat::E57: write_e57(file, cloud, path); break;
    case FileFormat::Auto: break;
  }
  file.commit();
}

}  // namespace nhnet
