// Point cloud file io: PLY (ascii, binary little/big endian), PCD (ascii, binary,
// binary_compressed), XYZ/XYZN text (x y z [nx ny nz] per line, whitespace separated), LAS
// 1.0-1.4 and LAZ (point formats 0-10), E57 (every scan, poses applied).
#pragma once

#include "nhnet/io/cloud.hpp"

#include <string>
#include <vector>

namespace nhnet {

enum class FileFormat { Auto, Ply, Pcd, Xyz, Las, Laz, E57 };

/// Format implied by a path's extension (.ply, .pcd, .xyz/.xyzn/.txt/.pts, .las, .laz, .e57);
/// Auto if unknown.
FileFormat format_from_extension(const std::string& path);

struct ReadOptions {
  /// Format to assume; Auto sniffs the content (magic line) and falls back on the extension.
  FileFormat format = FileFormat::Auto;
};

/// Reads a cloud. Non-finite coordinates are kept as they are (the estimator reports them).
/// Throws InputError naming the file and the problem (missing, empty, truncated, malformed,
/// declared size larger than the file, ...). Non-fatal notes (e.g. dropped PLY face element)
/// are appended to `warnings` when given.
Cloud read_cloud(const std::string& path, const ReadOptions& options = {},
                 std::vector<std::string>* warnings = nullptr);

struct WriteOptions {
  /// Format to write; Auto takes it from the extension of the path.
  FileFormat format = FileFormat::Auto;
  /// PLY/PCD: write ascii instead of binary (little endian).
  bool ascii = false;
};

/// Writes a cloud (points, normals as float nx ny nz when present, extras). LAS/LAZ: a cloud read
/// from LAS/LAZ with its point count unchanged keeps every attribute bit-exact, normals go into
/// extra-bytes fields NormalX/Y/Z; E57: one scan per sensor, normals as the "nor" extension. The
/// data goes to a temporary file in the same directory which is renamed over `path` only when
/// complete, so a failure never leaves a partial file. Throws OutputError naming the file and the
/// reason.
void write_cloud(const std::string& path, const Cloud& cloud, const WriteOptions& options = {});

}  // namespace nhnet
